"""`twip reproduce`'s report: the thesis's claims (claims.py), the runs (reproduce.py,
sweeps.py) and report.md (markdown.py), all from one report dict that is report.json."""
from twip.report.reproduce import DEFAULT_OUT, reproduce

__all__ = ["DEFAULT_OUT", "reproduce"]
