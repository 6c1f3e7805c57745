"""The value types and their maths, below everything that uses them.

:mod:`.properties` (``MassProperties``, ``ErrorBounds``), :mod:`.principal`,
:mod:`.frames` (``Pose``), :mod:`.resolution`, :mod:`.combine` (placed parts
summed), :mod:`.stretch` (moments under a linear map), :mod:`.errors`,
:mod:`.density_units` and :mod:`.records`.  They import only each other and
:mod:`massprops.core`; nothing here reads a file or prints.
"""
