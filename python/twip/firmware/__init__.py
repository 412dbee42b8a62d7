"""The same controller on the robot: `twip.firmware.export(scenario, out)` writes a folder a
firmware builds from (the C header of twip-ffi, the tuned controller's configuration as a C
initialiser, an Arduino-style example, a Makefile) and a recorded closed-loop run that
`make check` replays through the C ABI. See docs/firmware.md."""
from twip.firmware.export import FAMILIES, export  # noqa: F401
