"""`twip --help` loads only what the parser needs: not the commands' modules (the report,
plotting, sweeps) and not scipy (identification loads it on first use). Speed itself is
measured side by side, not asserted."""
import subprocess
import sys

PROBE = """
import sys
from twip.cli import build_parser
build_parser().format_help()
print(sorted(m for m in ("twip.cli.commands", "twip.sysid", "scipy", "matplotlib") if m in sys.modules))
"""


def test_the_help_loads_neither_the_commands_nor_scipy():
    done = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]", done.stdout


def test_identification_still_loads_on_first_use():
    import twip

    assert twip.identify.__module__.startswith("twip.sysid") and twip.Fit.__name__ == "Fit"
    from twip import RunLog  # noqa: F401  (from-imports reach the lazy names too)
