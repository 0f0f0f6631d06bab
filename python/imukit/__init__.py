"""imukit: capture, characterize, simulate and augment wearable IMUs, from Python.

The work is done by the C++ library (the compiled module imukit._imukit); arrays go in and
out as NumPy arrays, without copies where docs/python.md says so, and the GIL is released
while the library works. Errors of the library are raised as imukit.Error (a ValueError)
with the same message the C++ code and the `imukit` command print.
"""
from . import _imukit
from ._imukit import *  # noqa: F401,F403
from ._imukit import Error, __version__  # noqa: F401

__all__ = [name for name in dir(_imukit) if not name.startswith("_")]
