"""Settings for the whole suite."""

from hypothesis import settings

# Hypothesis' per-example deadline measures wall time, which a machine busy with other work
# stretches (a 1 ms example took 430 ms beside a CPU hog): the generated tests check what is
# decoded and refused, never how fast.
settings.register_profile("suite", deadline=None)
settings.load_profile("suite")
