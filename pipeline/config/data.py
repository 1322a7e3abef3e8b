"""Section `data` of params.yaml: data the user supplies from outside the repository (inD, SDD)."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class IndParams:
    """Section `data.ind` of params.yaml: where the user's own copy of inD is."""

    path: str | None = ""
    """The inD release folder (holding data/XX_tracks.csv), absolute or relative to the repository
    root; empty: inD is not provided (the stages record why and the report says so)."""
    labels: str | None = ""
    """Optional folder of hand-labelled masks XX_background_mask.png (values 1-5, the SDD classes of
    `ynet.segmentation.CLASS_NAMES`, the size of XX_background.png); they fine-tune the segmentation
    net. Empty: the SDD-trained net segments the backgrounds unchanged."""
    val_recordings: list[int] = field(default_factory=lambda: [7, 18, 30])
    """Whole train recordings held out for model selection (never location-4 recordings)."""

    def __post_init__(self) -> None:
        for name in ("path", "labels"):
            value = getattr(self, name)
            if value is None:  # `path:` with nothing after it in YAML: empty, always a str after
                object.__setattr__(self, name, "")
            elif not isinstance(value, str):
                raise ValueError(f"{name} must be a folder path (a string), got {value!r}")
        if self.labels and not self.path:
            raise ValueError("labels is set but path is empty: masks need the inD copy they label")
        if (not isinstance(self.val_recordings, list)
                or any(not isinstance(r, int) or isinstance(r, bool) or r < 0 for r in self.val_recordings)
                or len(set(self.val_recordings)) != len(self.val_recordings)):
            raise ValueError(f"val_recordings must be a list of distinct recording numbers, "
                             f"got {self.val_recordings!r}")

    @property
    def provided(self) -> bool:
        return bool(self.path)


@dataclass(frozen=True)
class SddParams:
    """Section `data.sdd` of params.yaml: where the user's own copy of the Stanford Drone Dataset is."""

    path: str | None = ""
    """The folder of the official SDD download holding `annotations/<scene>/video<k>/annotations.txt`
    (and `reference.jpg`), absolute or relative to the repository root; empty: the raw annotations
    are the fetched mirror's only (`data/raw/sdd`). Files the manifest pins must match it; the others
    are parsed and fingerprinted (`pipeline.data.sdd_sources`)."""

    def __post_init__(self) -> None:
        if self.path is None:  # `path:` with nothing after it in YAML: empty, always a str after
            object.__setattr__(self, "path", "")
        elif not isinstance(self.path, str):
            raise ValueError(f"path must be a folder path (a string), got {self.path!r}")

    @property
    def provided(self) -> bool:
        return bool(self.path)


@dataclass(frozen=True)
class DataParams:
    """Section `data` of params.yaml: data the user supplies from outside the repository."""

    ind: IndParams
    """inD (licence-restricted, never redistributed)."""
    sdd: SddParams = field(default_factory=SddParams)
    """Your own copy of SDD, beside the fetched mirror (default: none)."""
