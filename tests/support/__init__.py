"""What the tests share: rigs, processes, waits and clients, imported by name from here
and never from another test module or a conftest."""
