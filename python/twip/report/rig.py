"""The thesis-like robot checked against the thesis's measurements: each number the thesis
measured on its robot (its experiments' claims and Table 5.1/5.2 rows) beside the rig's, i.e.
the same run with `Realism.thesis_like()` in the loop. A row whose number a parameter of the
rig (the robot, the wheel, Γ, the reference) was fitted to is calibrated; the rest are the
rig's predictions."""
from __future__ import annotations

from typing import List

#: Conclusions drawn from measured numbers, not numbers measured: they have their own rows.
_CONCLUSIONS = ("table-5.1/fuzzy-beats-lqr-", "table-5.2/smc-beats-pid")


def rig_check(claims: List[dict]) -> List[dict]:
    """One row per measured number with a thesis-like run: id, claim, thesis, ideal (ours on
    the ideal plant), rig (None: that run fell), unit, holds (the claim with the rig), basis
    ("calibrated" or "prediction") and, when calibrated, what was fitted to it."""
    rows = []
    for c in claims:
        real = c.get("realism")
        if real is None or c["basis"] in ("duplicate", "input, deviated") or c["id"].startswith(_CONCLUSIONS):
            continue
        fitted = c["basis"] in ("calibrated", "partly calibrated")
        rows.append({"id": c["id"], "claim": c["claim"], "thesis": c["thesis"], "ideal": c["ours"], "rig": real["ours"],
                     "outcome": real["outcome"], "unit": c["unit"], "holds": bool(real.get("holds")),
                     "basis": "calibrated" if fitted else "prediction",
                     **({"fitted": c["reason"].split(";")[0]} if fitted else {})})
    return rows


def rig_summary(rows: List[dict]) -> dict:
    """How many of `rig_check`'s rows are predictions of the rig, and how many of those hold."""
    predictions = [r for r in rows if r["basis"] == "prediction"]
    return {"measured": len(rows), "calibrated": len(rows) - len(predictions), "predictions": len(predictions),
            "predictions_hold": sum(r["holds"] for r in predictions)}
