"""The task prior the intent estimator's node tests expect back from it."""

from __future__ import annotations

PRIOR = 4 / 7
"""Each task's prior probability: uniform over the seven task sets, four of which contain it."""

