"""Section `score_predictions` of params.yaml: the thresholds of the metrics beyond the paper's."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class ScorePredictionsParams:
    """Section `score_predictions` of params.yaml: the thresholds of the metrics beyond the
    paper's, computed from the stored long-term predictions (stage `score_predictions`)."""

    miss_threshold_m: float = 2.0
    """A window is a miss when its best endpoint is further than this from the true one, in
    metres, converted to pixels with each video's scale (SDD's estimated_scales.yaml): 2 m is the
    miss rate of Argoverse and nuScenes (about 50-70 px in SDD)."""
    collision_threshold_m: float = 0.2
    """Two agents at a shared frame collide when closer than this, in metres: TrajNet++'s two
    0.1 m person radii."""
    log_pdf_floor: float = -20.0
    """The KDE log-density of one step is clipped below here (Trajectron++'s
    log_pdf_lower_bound), so a step's NLL is at most -log_pdf_floor."""
    forbidden_classes: list[str] = field(default_factory=lambda: ["structure", "tree"])
    """Label classes a pedestrian cannot stand on: the off-limits share counts positions on them."""

    def __post_init__(self):
        for name in ("miss_threshold_m", "collision_threshold_m"):
            if not 0 < getattr(self, name) < float("inf"):
                raise ValueError(f"{name} must be a positive distance, got {getattr(self, name)}")
        if not -float("inf") < self.log_pdf_floor < 0:
            raise ValueError(f"log_pdf_floor must be a finite negative log-density, got "
                             f"{self.log_pdf_floor}")
        names = self.forbidden_classes
        if not isinstance(names, list) or not names or len(set(names)) != len(names) \
                or not all(isinstance(n, str) for n in names):
            raise ValueError(f"forbidden_classes must be a non-empty list of distinct class "
                             f"names, got {names!r}")
