"""The line engine across a process boundary.

A line worker (``worker``) owns the schedulers, pollers and state cache of its loop(s) and
serves them over two local channels; the API process holds a client (``proxy``) that offers
the schedulers' calling surface (``submit``, ``stop``, link state, events) and a mirror of the
state cache (``mirror``) fed by the worker's numbered changes, so that reads never cross the
channel. ``wire`` is the encoding both ends share.

The two channels: requests, replies, changes and events travel on one; stops on the other,
which each end reads first, so no queued request delays a stop on its way to the scheduler.
"""
