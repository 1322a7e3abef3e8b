"""Typed access to `params.yaml`: every section a stage reads, as a dataclass, and how to load it.

Each dataclass documents its fields and checks them in `__post_init__`. `load_section` builds one
from the YAML and fails loudly on unknown or missing keys, so a typo in `params.yaml` or in
`dvc exp run -S ...` is an error, not a silent default. `load_profile` picks a profiled section's
entry for the active `profile`. The models' own settings are here too, Y-net's (`YnetSettings`,
which builds a `ynet.config.YNetConfig`) and the trained baselines' (`SganConfig`, `PecnetConfig`),
so that code reading them need not import a training loop; `tests/test_params.py` checks every
class against `params.yaml`.
"""

from __future__ import annotations

import dataclasses
import re
import types
import typing
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import yaml

from pipeline.model_list import SHORT_TERM_MODELS, ours_first
from pipeline.splits import FOLD_TEST_SCENES, SDD_RAW_FPS, TRAIN_VIDEOS
from ynet.config import YNetConfig, upstream_max_distance

T = TypeVar("T")

PARAMS_FILE = Path("params.yaml")


class ParamsError(ValueError):
    """`params.yaml` does not match what a stage expects."""


def read_params(path: Path | str = PARAMS_FILE) -> dict[str, Any]:
    path = Path(path)
    try:
        with path.open() as f:
            params = yaml.safe_load(f)
    except FileNotFoundError as e:
        raise ParamsError(f"{path}: not found (run stages from the repository root)") from e
    if not isinstance(params, dict):
        raise ParamsError(f"{path}: expected a mapping at the top level")
    return params


SCALAR_TYPES = {bool: (bool,), int: (int,), float: (int, float), str: (str,)}


def union_options(hint: Any) -> tuple:
    """The types an annotation allows: (float, NoneType) for `float | None`, (int,) for int."""
    return (typing.get_args(hint) if typing.get_origin(hint) in (typing.Union, types.UnionType)
            else (hint,))


def scalar_type_error(hint: Any, value: Any) -> str | None:
    """Why `value` does not fit a plain scalar annotation (bool, int, float, str, or one of them
    `| None`), or None; any other annotation is left to the dataclass's own checks. A bool is no
    number here (YAML's `yes` for an epoch count is a typo, not 1)."""
    options = union_options(hint)
    kinds = [o for o in options if o is not type(None)]
    if not kinds or any(o not in SCALAR_TYPES for o in kinds):
        return None
    if value is None and type(None) in options:
        return None
    for kind in kinds:
        if isinstance(value, SCALAR_TYPES[kind]) and (kind is bool or not isinstance(value, bool)):
            return None
    wanted = " or ".join(k.__name__ for k in kinds) + (" or null" if type(None) in options else "")
    return f"expected {wanted}, got {type(value).__name__} {value!r}"


# A float as YAML 1.2 writes it: DVC (ruamel) reads `1e9` and `1e-3` as numbers, PyYAML (YAML 1.1,
# which needs a dot and a signed exponent) as strings
YAML12_FLOAT = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")


def wants_float(hint: Any) -> bool:
    """Whether a field annotated `hint` takes a float and no string (float, `float | None`)."""
    options = union_options(hint)
    return float in options and str not in options


def yaml12_floats(hint: Any, value: Any) -> Any:
    """`value` with every string YAML 1.2 reads as a float made one, where `hint` wants a float
    (a field, or the items of a list / the values of a dict of floats): `1e9` in params.yaml (or
    from `dvc exp run -S`) then reaches the field's own checks, as DVC read it, instead of failing
    as a string."""
    if isinstance(value, str) and wants_float(hint) and YAML12_FLOAT.fullmatch(value.strip()):
        return float(value)
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is list and isinstance(value, list) and args:
        return [yaml12_floats(args[0], item) for item in value]
    if origin is dict and isinstance(value, dict) and len(args) == 2:
        return {key: yaml12_floats(args[1], item) for key, item in value.items()}
    return value


def from_dict(cls: type[T], values: Any, where: str) -> T:
    """Build dataclass `cls` from a mapping; nested dataclass fields recurse."""
    if not isinstance(values, dict):
        raise ParamsError(f"{where}: expected a mapping, got {type(values).__name__}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(values) - set(fields))
    if unknown:
        raise ParamsError(f"{where}: unknown key(s) {unknown}; allowed: {sorted(fields)}")
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for name, value in values.items():
        hint = hints[name]
        if dataclasses.is_dataclass(hint):
            value = from_dict(hint, value, f"{where}.{name}")
        value = yaml12_floats(hint, value)
        wrong = scalar_type_error(hint, value)
        if wrong:
            raise ParamsError(f"{where}.{name}: {wrong}")
        kwargs[name] = value
    missing = [
        n for n, f in fields.items()
        if n not in kwargs and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ParamsError(f"{where}: missing key(s) {missing}")
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as e:
        raise ParamsError(f"{where}: {e}") from e


def load_section(cls: type[T], key: str, params: dict[str, Any] | None = None) -> T:
    """The section `key` of `params.yaml` (or of `params`) as a `cls` instance."""
    params = read_params() if params is None else params
    if key not in params:
        raise ParamsError(f"params.yaml: missing section '{key}'")
    return from_dict(cls, params[key], f"params.yaml:{key}")


def load_profile(cls: type[T], key: str, params: dict[str, Any] | None = None) -> T:
    """Section `key` for the active `profile` (params.yaml `profile: cpu|paper`) as a `cls`.

    Such a section holds one sub-mapping per profile, e.g. `ynet: {cpu: {...}, paper: {...}}`, so
    `dvc exp run -S profile=paper` switches every profiled stage at once.
    """
    params = read_params() if params is None else params
    profile = params.get("profile")
    if key not in params:
        raise ParamsError(f"params.yaml: missing section '{key}'")
    if not isinstance(params[key], dict) or profile not in params[key]:
        raise ParamsError(f"params.yaml:{key}: no settings for profile {profile!r}; "
                          f"profiles here: {sorted(params[key]) if isinstance(params[key], dict) else []}")
    return from_dict(cls, params[key][profile], f"params.yaml:{key}.{profile}")


# ---------------------------------------------------------------------------------------------
# Runtime: where torch runs, how long a training call may take


@dataclass
class RuntimeParams:
    """Section `runtime` of params.yaml: where torch runs and how long a training call may take."""

    device: str = "auto"
    """auto (CUDA when available) | cpu | cuda | cuda:N."""
    max_minutes: float = 0.0
    """Training stages save a mid-epoch checkpoint and stop (exit code 75) after this many minutes
    of one invocation; the next `dvc repro` resumes. 0 = no limit."""

    def __post_init__(self):
        parse_device_name(self.device)  # raises on a malformed name
        if self.max_minutes < 0:
            raise ValueError(f"max_minutes must be >= 0 (0 = no limit), got {self.max_minutes}")


def parse_device_name(name: str) -> tuple[str, int | None]:
    """'auto' | 'cpu' | 'cuda' | 'cuda:N' -> (kind, index); anything else is a ValueError."""
    if name in ("auto", "cpu", "cuda"):
        return name, None
    kind, _, index = name.partition(":")
    if kind == "cuda" and index.isdigit():
        return kind, int(index)
    raise ValueError(f"device must be auto, cpu, cuda or cuda:N, got {name!r}")


# ---------------------------------------------------------------------------------------------
# Data: sources, tracks, windows, splits


FETCH_SOURCES = ("sdd", "ynet-release", "sgan", "trajnet-sdd", "ethucy-scenes")


@dataclass
class FetchParams:
    sources: list[str] = field(default_factory=lambda: list(FETCH_SOURCES))
    """Sources to fetch; one `fetch@<source>` stage each."""
    locations: list[str | dict] = field(default_factory=lambda: ["../shared/data"])
    """Ordered places to try. A string is a mirror, a local folder or an http(s) base URL holding
    `<base>/<source>/<rel>`. A mapping `{name, sources: {<source>: {base, map}}}` says where each
    source lies upstream, in another layout (`UpstreamLocation`); `parsed_locations` reads both."""
    timeout_s: float = 60.0
    """Per-request timeout for http(s) locations."""

    def __post_init__(self):
        unknown = sorted(set(self.sources) - set(FETCH_SOURCES))
        if unknown:
            raise ValueError(f"unknown source(s) {unknown}; known: {list(FETCH_SOURCES)}")
        if not self.locations:
            raise ValueError("locations: at least one location is needed")
        names = [loc.name for loc in self.parsed_locations() if isinstance(loc, UpstreamLocation)]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"locations: upstream name(s) {twice} used twice; names tell them apart "
                             "in error messages")

    def parsed_locations(self) -> list[str | UpstreamLocation]:
        """`locations` checked and typed: strings stay, mappings become `UpstreamLocation`s. The
        raw YAML stays in `locations` (so params.yaml round-trips); this parses it on demand."""
        return [parse_location(entry, f"locations[{i}]") for i, entry in enumerate(self.locations)]


def is_url(location: str) -> bool | None:
    """True for http(s) URLs, False for local paths, None for other schemes (rejected)."""
    scheme = urllib.parse.urlparse(location).scheme
    if scheme in ("http", "https"):
        return True
    if scheme in ("", "file") or len(scheme) == 1:  # "C:" on Windows counts as a path
        return False
    return None


@dataclass(frozen=True)
class PathRule:
    """One rewrite of a manifest path: `prefix` (YAML `from`) is replaced by `to`, under `base`
    when given (a source split across folders or repositories), else under the source's base.

    A `prefix` ending in "/" is a folder and rewrites every path under it; any other non-empty
    `prefix` is one file and matches that path only (so `eth/` never catches `eth_ucy/...`); the
    empty prefix matches every path."""

    prefix: str
    to: str
    base: str | None = None

    def matches(self, rel: str) -> bool:
        folder = self.prefix == "" or self.prefix.endswith("/")
        return rel == self.prefix or (folder and rel.startswith(self.prefix))

    def apply(self, rel: str) -> str:
        return self.to + rel[len(self.prefix):]


@dataclass(frozen=True)
class UpstreamSource:
    """Where one source lies upstream: manifest path -> `<base>/<rewritten path>`."""

    base: str
    rules: tuple[PathRule, ...]

    def resolve(self, rel: str) -> str | None:
        """The upstream address (URL or local path) of manifest path `rel`, by the first rule that
        matches it; None when no rule does (the file is not offered)."""
        for rule in self.rules:
            if rule.matches(rel):
                return join_address(rule.base or self.base, rule.apply(rel))
        return None


@dataclass(frozen=True)
class UpstreamLocation:
    """A named location that holds each source it lists in that source's own upstream layout."""

    name: str
    sources: dict[str, UpstreamSource]


def join_address(base: str, path: str) -> str:
    """`base` + "/" + `path`, for a URL base (`path` percent-quoted, `base` taken as written) or a
    local folder; `path` is relative and "/"-separated."""
    if not path:
        return base.rstrip("/")
    return base.rstrip("/") + "/" + (urllib.parse.quote(path) if is_url(base) else path)


def _check_keys(value: Any, where: str, required: set[str], optional: set[str] = frozenset()) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"{where}: expected a mapping, got {type(value).__name__} {value!r}")
    unknown = sorted(set(map(str, value)) - required - optional)
    missing = sorted(required - set(value))
    if unknown or missing:
        raise ValueError(f"{where}: " + "; ".join(
            ([f"unknown key(s) {unknown}"] if unknown else [])
            + ([f"missing key(s) {missing}"] if missing else []))
            + f"; allowed: {sorted(required | optional)}")
    return value


def _check_base(base: Any, where: str) -> str:
    if not isinstance(base, str) or not base or is_url(base) is None:
        raise ValueError(f"{where}: {base!r} is not a folder path or an http(s) URL")
    return base


def _check_rel(value: Any, where: str) -> str:
    """A relative "/"-separated path or prefix: no leading "/", no "." or ".." segment, no "\\"."""
    if not isinstance(value, str):
        raise ValueError(f"{where}: expected a string, got {type(value).__name__} {value!r}")
    segments = value.rstrip("/").split("/") if value else []
    if value.startswith("/") or "\\" in value or any(s in ("", ".", "..") for s in segments):
        raise ValueError(f"{where}: {value!r} must be a relative path like 'a/b/' or 'a/b.txt' "
                         "(no leading '/', no '.', '..' or empty segment, no '\\')")
    return value


def parse_rule(raw: Any, where: str) -> PathRule:
    raw = _check_keys(raw, where, {"from", "to"}, {"base"})
    prefix, to = _check_rel(raw["from"], f"{where}.from"), _check_rel(raw["to"], f"{where}.to")
    folder = prefix == "" or prefix.endswith("/")
    if folder and not (to == "" or to.endswith("/")):
        raise ValueError(f"{where}: folder {prefix!r} must map to a folder ending in '/' (or ''), "
                         f"got {to!r}")
    if not folder and (to == "" or to.endswith("/")):
        raise ValueError(f"{where}: file {prefix!r} must map to a file path, got {to!r}")
    base = raw.get("base")
    return PathRule(prefix, to, None if base is None else _check_base(base, f"{where}.base"))


def parse_upstream_source(raw: Any, where: str) -> UpstreamSource:
    """A source's `{base, map}`; `map` left out means paths are the same upstream (`from: ''`)."""
    raw = _check_keys(raw, where, {"base"}, {"map"})
    base = _check_base(raw["base"], f"{where}.base")
    rules_raw = raw.get("map", [{"from": "", "to": ""}])
    if not isinstance(rules_raw, list) or not rules_raw:
        raise ValueError(f"{where}.map: expected a non-empty list of {{from, to[, base]}} rules")
    rules = tuple(parse_rule(r, f"{where}.map[{i}]") for i, r in enumerate(rules_raw))
    for later, rule in enumerate(rules):
        for earlier in range(later):
            if rules[earlier].matches(rule.prefix):
                raise ValueError(f"{where}.map[{later}] (from {rule.prefix!r}) is never used: "
                                 f"map[{earlier}] (from {rules[earlier].prefix!r}) matches its paths first")
    return UpstreamSource(base, rules)


def parse_location(raw: Any, where: str) -> str | UpstreamLocation:
    """A `fetch.locations` entry, checked: a mirror (string) or an upstream mapping."""
    if isinstance(raw, str):
        if is_url(raw) is None:
            raise ValueError(f"location {raw!r}: not a folder path or an http(s) URL")
        return raw
    raw = _check_keys(raw, where, {"name", "sources"})
    if not isinstance(raw["name"], str) or not raw["name"]:
        raise ValueError(f"{where}.name: expected a non-empty string, got {raw['name']!r}")
    where = f"{where} ({raw['name']})"
    if not isinstance(raw["sources"], dict) or not raw["sources"]:
        raise ValueError(f"{where}.sources: expected a mapping of source -> {{base, map}}")
    unknown = sorted(set(map(str, raw["sources"])) - set(FETCH_SOURCES))
    if unknown:
        raise ValueError(f"{where}.sources: unknown source(s) {unknown}; known: {list(FETCH_SOURCES)}")
    return UpstreamLocation(raw["name"], {
        source: parse_upstream_source(spec, f"{where}.sources.{source}")
        for source, spec in raw["sources"].items()})


@dataclass
class CompatParams:
    drop_first_row: bool = False
    """Reproduce the authors' `read_csv(header=0)` bug: drop the first annotation of every file."""


@dataclass
class SplitParams:
    val_videos: list[str] = field(default_factory=list)
    """Train videos held out for validation (model selection); whole videos, never test ones."""

    def __post_init__(self):
        not_train = sorted(set(self.val_videos) - TRAIN_VIDEOS)
        if not_train:
            raise ValueError(f"val_videos must be TrajNet train videos; not train: {not_train}")


@dataclass
class WindowParams:
    n_past: int = 5
    """Observed steps (n_p) at the target frame rate."""
    horizons: list[int] = field(default_factory=lambda: [5, 10, 15, 20, 30, 40, 50, 60])
    """Prediction horizons t_f in seconds; one window table each."""
    raw_fps: int = 30
    """Frame rate of the raw annotations."""
    target_fps: int = 1
    """Frame rate of the windows; raw_fps must be a multiple of it."""
    label: str = "Pedestrian"
    """Agent class kept."""
    release_horizon: int = 30
    """t_f of the authors' released windows."""

    def __post_init__(self):
        if self.n_past < 2:
            raise ValueError("n_past must be at least 2 (a velocity needs two points)")
        if not self.horizons or min(self.horizons) < 1:
            raise ValueError("horizons must be a non-empty list of positive seconds")
        if self.raw_fps < 1 or self.target_fps < 1:
            raise ValueError(f"raw_fps and target_fps must be >= 1, got {self.raw_fps}, {self.target_fps}")
        if self.release_horizon < 1:
            raise ValueError(f"release_horizon must be >= 1 s, got {self.release_horizon}")
        if self.raw_fps % self.target_fps:
            raise ValueError(f"raw_fps {self.raw_fps} is not a multiple of target_fps {self.target_fps}")

    @property
    def stride(self) -> int:
        """Raw frames between two kept frames."""
        return self.raw_fps // self.target_fps

    def window_length(self, t_f: int) -> int:
        return self.n_past + t_f * self.target_fps


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


# ---------------------------------------------------------------------------------------------
# Scene segmentation: labels, U-Net, semantic maps


@dataclass(frozen=True)
class LabelsParams:
    """How the report overlays of the hand labels look (the label maps themselves are lossless)."""

    overlay_scale: float = 0.25
    """Overlays are written at this fraction of the original image size."""
    overlay_alpha: float = 0.45
    """Weight of the class colour over the image in the overlays."""

    def __post_init__(self) -> None:
        if not 0 < self.overlay_scale <= 1:
            raise ValueError(f"overlay_scale must be in (0, 1], got {self.overlay_scale}")
        if not 0 <= self.overlay_alpha <= 1:
            raise ValueError(f"overlay_alpha must be in [0, 1], got {self.overlay_alpha}")


@dataclass(frozen=True)
class AugmentParams:
    """Ranges of the random augmentations (all zero / False = plain random crops)."""

    rotate_deg: float = 180.0
    """Rotation angle drawn uniformly from [-rotate_deg, rotate_deg]; drone views have no 'up'."""
    flip: bool = True
    """Mirror with probability 1/2 (with free rotation this covers vertical flips too)."""
    scale_min: float = 0.75
    """Smallest zoom factor; factors are log-uniform in [scale_min, scale_max] (>1 zooms out)."""
    scale_max: float = 1.33
    """Largest zoom factor."""
    perspective: float = 0.05
    """Each crop corner moves by up to this fraction of the crop size (perspective distortion)."""
    noise_std: float = 0.03
    """Gaussian pixel noise with std drawn uniformly from [0, noise_std] (image in [0, 1])."""
    blur_prob: float = 0.3
    """Probability of a Gaussian blur."""
    blur_sigma: float = 1.5
    """Blur sigma drawn uniformly from [0.3, blur_sigma] pixels."""
    brightness: float = 0.15
    """Additive brightness shift drawn uniformly from [-brightness, brightness]."""
    contrast: float = 0.25
    """Contrast factor drawn uniformly from [1 - contrast, 1 + contrast] about the crop mean."""
    colour: float = 0.1
    """Per-channel gain drawn uniformly from [1 - colour, 1 + colour] (colour cast)."""

    def __post_init__(self) -> None:
        if not 0 <= self.rotate_deg <= 180:
            raise ValueError(f"rotate_deg must be in [0, 180], got {self.rotate_deg}")
        if not 0 < self.scale_min <= self.scale_max:
            raise ValueError(f"need 0 < scale_min <= scale_max, got {self.scale_min}, {self.scale_max}")
        if not 0 <= self.perspective < 0.25:
            raise ValueError(f"perspective must be in [0, 0.25), got {self.perspective}")
        if not 0 <= self.blur_prob <= 1:
            raise ValueError(f"blur_prob must be in [0, 1], got {self.blur_prob}")
        if self.blur_sigma < 0.3:
            raise ValueError(f"blur_sigma must be >= 0.3, got {self.blur_sigma}")
        for name in ("noise_std", "brightness"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("contrast", "colour"):
            if not 0 <= getattr(self, name) < 1:
                raise ValueError(f"{name} must be in [0, 1), got {getattr(self, name)}")


@dataclass(frozen=True)
class SegmentationParams:
    """Section `segmentation` of params.yaml, one per profile (`segmentation: {cpu: ..., paper: ...}`)."""

    base_channels: int
    """U-Net width of the first level, doubled at every level down (cpu: 16; paper: 32)."""
    depth: int
    """Number of 2x downsamplings of the U-Net; `pad_multiple` and `crop` must divide by 2**depth."""
    epochs: int
    """Passes over the training videos."""
    crops_per_image: int
    """Random crops drawn from every training video per epoch (paper: 1, one per image)."""
    lr_drop_epoch: int
    """From this epoch on the learning rate is multiplied by `lr_drop_factor` (paper: 1500)."""
    bf16: bool
    """On the CPU, bfloat16 autocast + channels-last: ~3x faster on CPUs with AMX/AVX512-BF16, slow
    elsewhere. On CUDA both are always on, whatever this says (`pipeline.device.autocast`)."""
    seed: int = 0
    """Seeds weight init and the crop/augmentation stream (one numpy stream per epoch)."""
    downsample: int = 4
    """Images and labels are shrunk by this factor (paper: 4 for SDD); Y-net's resize is 1/downsample."""
    pad_multiple: int = 32
    """Downsampled images are padded (padding class) to a multiple of this (paper: 32)."""
    crop: int = 256
    """Side of the square training crops (paper: 256)."""
    batch_size: int = 4
    """Crops per optimiser step (paper: 4)."""
    lr: float = 1e-4
    """Adam learning rate (paper: 1e-4)."""
    lr_drop_factor: float = 0.1
    """Learning-rate factor from `lr_drop_epoch` on (paper: 1e-4 -> 1e-5)."""
    augment: AugmentParams = field(default_factory=AugmentParams)
    """Ranges of the random augmentations."""
    threads: int = 1
    """torch CPU threads. One: on 2 cores two threads ran about 4x slower than one, and a
    single-threaded stage runs beside another one under `make repro` (tools/parallel_repro.py)."""

    def __post_init__(self) -> None:
        for name in ("base_channels", "depth", "epochs", "crops_per_image", "downsample",
                     "pad_multiple", "crop", "batch_size", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.lr_drop_epoch < 0:
            raise ValueError(f"lr_drop_epoch must be >= 0, got {self.lr_drop_epoch}")
        if not self.lr > 0 or not 0 < self.lr_drop_factor <= 1:
            raise ValueError(f"need lr > 0 and 0 < lr_drop_factor <= 1, got {self.lr}, "
                             f"{self.lr_drop_factor}")
        if self.pad_multiple % 2**self.depth or self.crop % 2**self.depth:
            raise ValueError(f"depth={self.depth}: pad_multiple ({self.pad_multiple}) and crop "
                             f"({self.crop}) must be divisible by 2**depth")


SEMANTIC_SOURCES = ("predicted", "labels")


@dataclass(frozen=True)
class SemanticParams:
    """Section `semantic` of params.yaml: which scene maps Y-net gets, and at what resolution."""

    source: str = "predicted"
    """'predicted' (the U-Net's softmax) or 'labels' (one-hot hand labels: the oracle ablation)."""
    resize: float = 0.25
    """Maps are stored at this fraction of the original image size (Y-net's SDD resize, 0.25)."""

    def __post_init__(self) -> None:
        if self.source not in SEMANTIC_SOURCES:
            raise ValueError(f"source must be one of {SEMANTIC_SOURCES}, got {self.source!r}")
        if not 0 < self.resize <= 1:
            raise ValueError(f"resize must be in (0, 1], got {self.resize}")


# ---------------------------------------------------------------------------------------------
# Y-net: its model and training settings (section ynet.<profile>)


# (quarter turns counter-clockwise, horizontal flip), the authors' 8 augmentations
# (`pipeline.data.ynet_data.augment` applies one).
AUGMENTATIONS = tuple((turns, flip) for turns in range(4) for flip in (False, True))
LR_SCHEDULES = ("constant", "cosine")


# Settings Y-net had once, at the only values any profile ran them with (`YnetSettings.from_saved`).
RETIRED_SETTINGS = {"distance_norm": "upstream", "mix_scenes": False, "weight_average_decay": 0.0}


@dataclass
class YnetSettings:
    """Section `ynet.<profile>` of params.yaml: Y-net's model and training settings."""

    resize: float = 0.25
    """Scale of maps and coordinates relative to the original image (authors: 0.25 for SDD)."""
    epochs: int = 300
    """Training epochs."""
    batch_size: int = 8
    """Windows per batch (all of one scene)."""
    learning_rate: float = 1e-4
    """Adam learning rate."""
    augmentations: int = 8
    """How many of the 8 rotation/flip variants each scene is seen under per epoch (8 = all)."""
    loss_scale: float = 1000.0
    """Factor on both BCE losses (authors: 1000)."""
    kernel_size: int = 31
    """Side of the Gaussian ground-truth kernel, pixels of the resized map."""
    sigma: float = 4.0
    """Standard deviation of the Gaussian ground truth, pixels of the resized map."""
    waypoints: list[int] = field(default_factory=lambda: [14, 29])
    """Future step indices conditioning the trajectory decoder; the last is the goal."""
    encoder_channels: list[int] = field(default_factory=lambda: [32, 32, 64, 64, 64])
    decoder_channels: list[int] = field(default_factory=lambda: [64, 64, 64, 32, 32])
    distance_gain: float = 1.0
    """Multiplies the distance maps, the authors' divided by their constant (1 = the authors').
    Their slope is tiny (2 / 371 per pixel at resize 0.125), so the decoders need large weights to
    turn a distance map into a sharp peak; a steeper input reaches those in far fewer steps (see
    the README's profile table)."""
    seed: int = 0
    """Seeds weights, shuffling and augmentation draws."""
    threads: int = 2
    """CPU threads for torch."""
    semantic_classes: int = 6
    """Channels of the scene map: SDD 6 (5 classes + padding), ETH/UCY 3 (road, not road, padding)."""
    steps_per_epoch: int = 0
    """Optimiser steps per epoch: the first of the epoch's shuffled batches; 0 = all of them."""
    head_bias: float | None = None
    """Initial bias of the decoders' output logits (see `ynet.config.YNetConfig.head_bias`);
    None = PyTorch's default, as the authors."""
    crop: int = 0
    """0: the model sees whole scenes (the authors). > 0 (a multiple of 32): a crop x crop window
    around each agent in training, validation and scoring (`ynet_data.window_inputs`); short
    horizons whose futures stay near the agent then cost a fraction of the pixels."""
    crop_lead_steps: float = 0.0
    """The crop is centred this many steps of the agent's last observed velocity ahead of it."""
    bf16: bool = False
    """bfloat16 autocast for the training forward passes on the CPU (about 1.7x on CPUs with
    AVX512-BF16 at batch 16; losses stay float32). CUDA always trains under bfloat16 autocast."""
    lr_schedule: str = "constant"
    """'constant', or 'cosine': the learning rate falls from `learning_rate` to 0 along a half
    cosine over the run's steps (a pure function of the step, so a resumed run follows it too)."""
    trajectory_lr_scale: float = 1.0
    """Multiplies the trajectory decoder's learning rate (schedule included); 1 = one rate for the
    whole model, as the authors. A short-term Y-net on crops learns its paths more slowly than its
    goals (README: its paths lose to straight lines towards the same goals)."""
    grad_clip_norm: float = 0.0
    """0: no clipping (the authors). > 0: before each step the gradients are scaled down so that
    their global L2 norm is at most this (`torch.nn.utils.clip_grad_norm_`): a rare huge batch
    gradient then moves the weights no further than a typical one. Losses are `loss_scale` times
    the BCE, so the norm's scale is that of the scaled loss."""

    def __post_init__(self):
        if not 0 < self.resize <= 1:
            raise ValueError(f"resize must be in (0, 1], got {self.resize}")
        if not 1 <= self.augmentations <= len(AUGMENTATIONS):
            raise ValueError(f"augmentations must be 1..{len(AUGMENTATIONS)}")
        if self.distance_gain <= 0:
            raise ValueError("distance_gain must be positive")
        if min(self.epochs, self.batch_size, self.semantic_classes) < 1:
            raise ValueError("epochs, batch_size and semantic_classes must be positive")
        if self.steps_per_epoch < 0:
            raise ValueError("steps_per_epoch must be >= 0 (0 = every batch)")
        if self.trajectory_lr_scale <= 0:
            raise ValueError(f"trajectory_lr_scale must be positive, got {self.trajectory_lr_scale}")
        if self.grad_clip_norm < 0:
            raise ValueError(f"grad_clip_norm must be >= 0 (0 = off), got {self.grad_clip_norm}")
        if self.lr_schedule not in LR_SCHEDULES:
            raise ValueError(f"lr_schedule must be one of {LR_SCHEDULES}, got {self.lr_schedule!r}")
        if self.crop < 0 or self.crop % 32:
            raise ValueError(f"crop must be 0 or a multiple of 32, got {self.crop}")

    def model_config(self, n_past: int, n_future: int) -> YNetConfig:
        return YNetConfig(obs_len=n_past, pred_len=n_future, semantic_classes=self.semantic_classes,
                          encoder_channels=tuple(self.encoder_channels),
                          decoder_channels=tuple(self.decoder_channels),
                          waypoints=tuple(self.waypoints), head_bias=self.head_bias)

    @classmethod
    def from_saved(cls, saved: dict) -> YnetSettings:
        """The settings a Y-net model file records (`ynet_training.train`). Files written while
        `distance_norm`, `mix_scenes` and `weight_average_decay` were settings record them too:
        read at the only values the pipeline ran them with, an error naming them otherwise."""
        other = {key: saved[key] for key in RETIRED_SETTINGS
                 if key in saved and saved[key] != RETIRED_SETTINGS[key]}
        if other:
            raise ValueError(f"a model trained with settings this code no longer has: {other}")
        return cls(**{key: value for key, value in saved.items() if key not in RETIRED_SETTINGS})

    @property
    def max_distance(self) -> float:
        return upstream_max_distance(self.resize) / self.distance_gain


# ---------------------------------------------------------------------------------------------
# Y-net scoring and the Y-net horizons


@dataclass
class TtstParams:
    temperature: float = 1.8
    """Goal and waypoint maps are sigmoid(logits / temperature) before sampling."""
    rel_threshold: float = 0.002
    """Pixels below rel_threshold * max are never sampled."""

    def __post_init__(self):
        if not self.temperature > 0:
            raise ValueError(f"temperature must be > 0, got {self.temperature}")
        if not 0 <= self.rel_threshold < 1:
            raise ValueError(f"rel_threshold must be in [0, 1), got {self.rel_threshold}")


@dataclass
class CwsParams:
    sigma_factor: float = 6.0
    """Prior sigma = (distance + 5) / sigma_factor."""
    ratio: float = 2.0
    """Prior sigma across the direction of travel is divided by this."""
    rot: bool = True
    """Rotate the prior to the direction of travel."""

    def __post_init__(self):
        for name in ("sigma_factor", "ratio"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")


@dataclass
class EvalParams:
    k_e: int = 20
    """Goals per window for the main result."""
    k_a: int = 1
    """Paths per goal for the main result."""
    rounds: int = 3
    """Seeded evaluation rounds of the main result; mean and spread are reported."""
    ablation_rounds: int = 1
    """Rounds of each Table 3 ablation row (0 = skip the ablation)."""
    ka_grid_k_e: list[int] = field(default_factory=lambda: [20])
    """K_e values of the K_a figure's grid (empty = skip the grid)."""
    ka_grid_k_a: list[int] = field(default_factory=lambda: [1, 2, 5])
    """K_a values of the K_a figure's grid."""
    seed: int = 0
    """Round r uses seed + r."""
    batch_size: int = 4
    """Windows per forward pass (one scene per batch)."""
    chunk_size: int = 4
    """Samples per window decoded together by the trajectory decoder."""
    bf16: bool = False
    """bfloat16 autocast for the convolutions (faster on CPUs with AMX; positions change slightly)."""
    threads: int = 2
    """torch CPU threads for scoring (training's are `ynet.<profile>.threads`: a model trained on
    one thread, beside another training, is scored alone on every core)."""
    qualitative_scenes: list[str] = field(default_factory=lambda: ["hyang_0", "little_2", "nexus_6"])
    """Test scenes whose longest-moving window is drawn in the qualitative figure."""

    def __post_init__(self):
        if min(self.k_e, self.k_a, self.rounds, self.batch_size, self.chunk_size, self.threads) < 1:
            raise ValueError("k_e, k_a, rounds, batch_size, chunk_size and threads must be positive")


@dataclass(frozen=True)
class HorizonParams:
    """Section `ynet_horizons.<profile>` of params.yaml."""

    epochs: dict[int, int] = field(default_factory=dict)
    """Horizon (s) -> training epochs, for the horizons this profile trains Y-net at (the other
    settings are `ynet.<profile>`'s); any other horizon gets a 'not run' record."""
    rounds: int = 3
    """Evaluation rounds (TTST + CWS, K_e from `eval.<profile>`, K_a = 1)."""
    why_subset: str = ""
    """Shown in the report for a horizon this profile does not train."""
    init_from_main: bool = False
    """Start each horizon from the main (30-s) Y-net's weights, its two output heads stretched to
    the horizon (`ynet.model.weights_for_horizon`), instead of a seeded random init (the authors')."""

    def __post_init__(self):
        if self.rounds < 1 or any(int(e) < 1 for e in self.epochs.values()):
            raise ValueError("epochs and rounds must be >= 1")

    @property
    def horizons(self) -> list[int]:
        return sorted(int(h) for h in self.epochs)


def seed_list_error(seeds: Any) -> str | None:
    """Why `seeds` is not a list of distinct non-negative integer seeds, or None."""
    if not isinstance(seeds, list) or any(isinstance(s, bool) or not isinstance(s, int) or s < 0
                                          for s in seeds):
        return f"must be non-negative integer seeds, got {seeds}"
    if len(set(seeds)) != len(seeds):
        return f"holds a seed twice: {seeds}"
    return None


@dataclass(frozen=True)
class YnetSeedsParams:
    """Section `ynet_seeds.<profile>`: the main Y-net trained again with other training seeds
    (stages `train_ynet_seed@<slot>`, `evaluate_ynet_seed@<slot>`), for the report's training-seed
    spread. The stages DVC builds are the slots `ynet_seeds.slots` (`ynet_seed_slots`); a slot not
    listed here writes a not-run record giving `why_not`."""

    seeds: list[int] = field(default_factory=list)
    """Training seeds besides `ynet.<profile>.seed` (the main model); [] trains none."""
    why_not: str = ""
    """Why this profile trains no (or only these) extra seeds; required when `seeds` is empty."""

    def __post_init__(self):
        wrong = seed_list_error(self.seeds)
        if wrong:
            raise ValueError(f"seeds {wrong}")
        if not self.seeds and not self.why_not.strip():
            raise ValueError("why_not must say why this profile trains no extra Y-net seed")

    def not_run_reason(self, profile: str, seed: int | None = None) -> str:
        """Why Y-net is not trained with `seed` (None: with any extra seed) in `profile`."""
        what = f"with seed {seed}" if seed is not None else "with extra training seeds"
        reason = (f"Y-net is not trained {what} in the {profile} profile (its extra seeds here: "
                  f"{', '.join(map(str, self.seeds)) or 'none'})")
        return f"{reason}: {self.why_not}" if self.why_not.strip() else reason


def ynet_main_seed(params: dict[str, Any]) -> int:
    """`ynet.<profile>.seed` alone (the main Y-net's training seed), for a stage that declares only
    that key of the section (`YnetSettings` itself lives with the training code)."""
    profile = params.get("profile")
    seed = params.get("ynet", {}).get(profile, {}).get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParamsError(f"params.yaml:ynet.{profile}.seed: expected a non-negative integer seed, "
                          f"got {seed!r}")
    return seed


def ynet_seed_slots(params: dict[str, Any]) -> list[int]:
    """`ynet_seeds.slots`: the seeds the `train_ynet_seed` / `evaluate_ynet_seed` stages exist for."""
    section = params.get("ynet_seeds")
    if not isinstance(section, dict) or "slots" not in section:
        raise ParamsError("params.yaml: missing ynet_seeds.slots")
    wrong = seed_list_error(section["slots"])
    if wrong:
        raise ParamsError(f"params.yaml:ynet_seeds.slots {wrong}")
    return list(section["slots"])


# ---------------------------------------------------------------------------------------------
# Baselines


@dataclass
class SganConfig:
    """Section `sgan.<profile>` of params.yaml: S-GAN's model and training settings
    (`pipeline.harness.baselines.sgan`)."""

    epochs: int = 200
    """Training epochs (passes over the training windows); the best on val is kept."""
    batch_size: int = 64
    """Windows per batch (whole co-occurrence groups, so about this many)."""
    learning_rate: float = 1e-3
    """Adam learning rate of generator and discriminator."""
    clip_g: float = 1.5
    """Generator gradient-norm clip (0: none)."""
    clip_d: float = 0.0
    """Discriminator gradient-norm clip (0: none)."""
    d_steps: int = 2
    """Discriminator updates per generator update."""
    best_of_k: int = 10
    """Samples the variety loss takes the best of."""
    l2_weight: float = 1.0
    """Weight of the variety (best-of-k L2) loss against the adversarial loss."""
    real_label: list[float] = field(default_factory=lambda: [0.7, 1.2])
    """Range the discriminator's target for real tracks (and the generator's) is drawn from."""
    fake_label: list[float] = field(default_factory=lambda: [0.0, 0.3])
    """Range the discriminator's target for generated tracks is drawn from."""
    embedding_dim: int = 16
    """Width of the displacement / relative-position embeddings."""
    encoder_hidden: int = 32
    """Hidden size of the generator's encoder LSTM."""
    decoder_hidden: int = 32
    """Hidden size of the decoder LSTM (its initial state: context + noise)."""
    noise_dim: int = 8
    """Gaussian noise entries of the decoder's initial state."""
    bottleneck_dim: int = 32
    """Output width of the pooling module."""
    pool_hidden: int = 512
    """Hidden width of the pooling module's pre-pool MLP."""
    mlp_dim: int = 64
    """Hidden width of the context MLP and of the discriminator's classifier."""
    discriminator_hidden: int = 48
    """Hidden size of the discriminator's LSTM."""
    coord_scale: float = 20.0
    """Pixels per network unit (about one step of walking at 1 FPS)."""
    val_k: int = 20
    """Samples per window when scoring the validation split (min-over-K ADE selects the epoch)."""

    def __post_init__(self):
        positive = ("epochs", "batch_size", "d_steps", "best_of_k", "embedding_dim", "encoder_hidden",
                    "bottleneck_dim", "pool_hidden", "mlp_dim", "discriminator_hidden", "val_k")
        for name in positive:
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if not 0 <= self.noise_dim < self.decoder_hidden:
            raise ValueError("noise_dim must be in [0, decoder_hidden)")
        if self.learning_rate <= 0 or self.coord_scale <= 0:
            raise ValueError("learning_rate and coord_scale must be > 0")
        if self.clip_g < 0 or self.clip_d < 0 or self.l2_weight < 0:
            raise ValueError("clip_g, clip_d and l2_weight must be >= 0")
        for name in ("real_label", "fake_label"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: [low, high] with low <= high")


@dataclass
class PecnetConfig:
    """Section `pecnet.<profile>` of params.yaml: PECNet's model and training settings
    (`pipeline.harness.baselines.pecnet`)."""

    epochs: int = 650
    """Training epochs; the best on val is kept."""
    batch_size: int = 512
    """Windows per batch (whole co-occurrence groups, so about this many)."""
    learning_rate: float = 3e-4
    """Adam learning rate."""
    past_hidden: list[int] = field(default_factory=lambda: [512, 256])
    """Hidden widths of the past encoder (2 n_p -> ... -> feature_dim)."""
    endpoint_hidden: list[int] = field(default_factory=lambda: [8, 16])
    """Hidden widths of the endpoint encoder (2 -> ... -> feature_dim)."""
    latent_hidden: list[int] = field(default_factory=lambda: [8, 50])
    """Hidden widths of the latent encoder (2 feature_dim -> ... -> 2 latent_dim)."""
    decoder_hidden: list[int] = field(default_factory=lambda: [1024, 512, 1024])
    """Hidden widths of the endpoint decoder (feature_dim + latent_dim -> ... -> 2)."""
    predictor_hidden: list[int] = field(default_factory=lambda: [1024, 512, 256])
    """Hidden widths of the path predictor (-> 2 (n_f - 1))."""
    nonlocal_hidden: list[int] = field(default_factory=lambda: [256, 128, 64])
    """Hidden widths of the non-local theta, phi and g MLPs."""
    nonlocal_dim: int = 128
    """Width of the non-local embedding whose dot products weigh the neighbours."""
    nonlocal_rounds: int = 3
    """Rounds of non-local social pooling before the path predictor."""
    feature_dim: int = 16
    """Width of the past and endpoint features."""
    latent_dim: int = 16
    """Width of the latent z."""
    sigma: float = 1.3
    """Standard deviation of z at test time (truncation trick)."""
    neighbour_radius: float = 100.0
    """Pixels: co-occurring agents closer than this at some observed step pool together."""
    data_scale: float = 1.86
    """Factor applied to origin-shifted pixel coordinates."""
    position_scale: float = 1000.0
    """Pixels per unit of the absolute-position input."""
    kl_weight: float = 1.0
    """Weight of the KL term (summed over batch and latent dimensions); see "Loss balance"."""
    path_weight: float = 1.0
    """Weight of the path MSE."""
    reverse_augment: bool = True
    """Add every training window played backwards."""
    val_k: int = 20
    """Samples per window when scoring the validation split (min-over-K ADE selects the epoch)."""

    def __post_init__(self):
        for name in ("epochs", "batch_size", "nonlocal_dim", "feature_dim", "latent_dim", "val_k"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        if self.nonlocal_rounds < 0:
            raise ValueError("nonlocal_rounds must be >= 0")
        for name in ("learning_rate", "sigma", "neighbour_radius", "data_scale", "position_scale"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0")
        if self.kl_weight < 0 or self.path_weight < 0:
            raise ValueError("kl_weight and path_weight must be >= 0")
        for name in ("past_hidden", "endpoint_hidden", "latent_hidden", "decoder_hidden",
                     "predictor_hidden", "nonlocal_hidden"):
            widths = getattr(self, name)
            if not isinstance(widths, list) or any(int(w) != w or w < 1 for w in widths):
                raise ValueError(f"{name} must be a list of positive widths, got {widths}")


@dataclass
class TrainBaselineParams:
    seed: int
    """Seed of all randomness in training (initialisation, batches, noise)."""
    threads: int
    """torch CPU threads."""

    def __post_init__(self):
        if self.threads < 1:
            raise ValueError("threads must be >= 1")


@dataclass
class BaselineSeedsParams:
    """Section `baseline_seeds`: every trained long-term baseline again with other training seeds
    (stages `train_baseline_seed`, `evaluate_baseline_seed`, `evaluate_rpecnet_seed`), so the report
    can show how far training alone moves the metrics. One list for both profiles: DVC 3.67's
    matrix cannot take `${baseline_seeds.${profile}}`."""

    extra: list[int] = field(default_factory=lambda: [1, 2])
    """Training seeds besides `train_baseline.seed` (whose models are the report's main numbers);
    [] trains none."""

    def __post_init__(self):
        wrong = seed_list_error(self.extra)
        if wrong:
            raise ValueError(f"extra {wrong}")


@dataclass(frozen=True)
class EpochSelectionStudyParams:
    """Section `epoch_selection_study`: the split-half study of the stage `epoch_selection`, which
    compares the epoch selection rules on validation windows alone
    (`pipeline.harness.epoch_selection`)."""

    n_splits: int = 200
    """Random halvings of each run's validation windows (each half chooses once)."""
    seed: int = 0
    """Seed of the halvings."""

    def __post_init__(self):
        if self.n_splits < 1:
            raise ValueError("n_splits must be >= 1")


@dataclass(frozen=True)
class PecnetTestSelectionParams:
    """Section `pecnet_test_selection`: a labelled compat diagnostic (stage `pecnet_test_selection`),
    never a headline number. Upstream PECNet scores the test set after every epoch and reports the
    best test ADE and the best test FDE over epochs (selection on test); the stage retrains PECNet as
    `train_baseline@pecnet-<t_f>` does, scores the test windows after every epoch and reports both
    that and the epoch kept on validation."""

    horizons: list[int] = field(default_factory=lambda: [30])
    """t_f (s) retrained; each needs its `data/horizon_windows/tf<t_f>.parquet` and
    `metrics/baselines/train_pecnet_tf<t_f>.json` among the stage's deps."""
    k: int = 20
    """Samples per test window, best of K (the paper's K = 20)."""
    seed: int = 0
    """Seed of the test sampling, the same after every epoch (epochs differ by weights alone)."""

    def __post_init__(self):
        if not self.horizons or any(isinstance(h, bool) or not isinstance(h, int) or h < 2
                                    for h in self.horizons):
            raise ValueError(f"horizons must be a non-empty list of t_f >= 2 s, got {self.horizons}")
        if len(set(self.horizons)) != len(self.horizons):
            raise ValueError(f"horizons repeat: {self.horizons}")
        if self.k < 1:
            raise ValueError(f"k must be >= 1, got {self.k}")


@dataclass(frozen=True)
class ShortTermPecnetTestSelectionParams:
    """Section `short_term_pecnet_test_selection`: the compat switch of stage
    `short_term_pecnet_test_selection@<fold>`, never a headline number. On the folds listed, PECNet
    is retrained as the headline trains it and its test windows scored after every epoch (upstream's
    selection on test); on the others the stage records that it is switched off."""

    folds: list[str] = field(default_factory=list)
    """ETH/UCY folds the diagnostic runs on ([]: switched off)."""

    def __post_init__(self):
        unknown = sorted(set(self.folds) - set(FOLD_TEST_SCENES))
        if unknown:
            raise ValueError(f"folds {unknown} are not ETH/UCY folds ({', '.join(FOLD_TEST_SCENES)})")
        if len(set(self.folds)) != len(self.folds):
            raise ValueError(f"folds repeat: {self.folds}")


@dataclass
class EvaluateBaselineParams:
    k: int
    """Samples per window; the metric takes the best of them (paper: 20)."""
    split: str
    """Split scored: `test` for the benchmark, `val` while developing."""
    rounds: int
    """Independently seeded sampling rounds (seeds seed, seed+1, ...); mean and spread reported."""
    seed: int
    """Seed of the first round."""
    threads: int
    """torch CPU threads."""
    epoch_selection: str = "raw"
    """Which kept epoch of a trained baseline is scored: `raw` (lowest validation ADE) or a smoothed
    rule of `pipeline.harness.epoch_selection` (chosen by the stage `epoch_selection`'s study;
    checked there, where the rules are defined)."""

    def __post_init__(self):
        if self.k < 1 or self.rounds < 1 or self.threads < 1:
            raise ValueError("k, rounds and threads must be >= 1")
        if self.split not in ("train", "val", "test"):
            raise ValueError(f"split must be train, val or test, got {self.split!r}")


@dataclass(frozen=True)
class RpecnetRolloutsParams:
    """Section `rpecnet_rollouts`: the diagnostic stage `rpecnet_rollouts`, which rolls the
    t_f = 5 PECNet out in several ways (`pipeline.harness.baselines.rpecnet.VARIANTS`) to see
    which of them gives the compounding error of the paper's R-PECNet. Never the headline."""

    variants: list[str] = field(default_factory=lambda: [
        "independent", "shared_latent", "mean_fed_back", "original_frame"])
    """Roll-outs scored on the choice split (names checked against the variants the code has)."""
    horizons: list[int] = field(default_factory=lambda: [30])
    """t_f (seconds) of the horizon tables scored."""
    k: int = 20
    """Samples per window, best of K (independent minima of ADE and FDE, the headline protocol)."""
    seed: int = 0
    """Seed of every variant's sampling generator (each variant and split from a fresh one)."""
    split_for_choice: str = "val"
    """Split the variant is chosen on; never test (the chosen one alone is then scored on test)."""
    target_fde_over_ade: float = 2.872
    """The chosen variant's mean FDE / mean ADE is the nearest to this: the paper's R-PECNet at
    t_f = 30 s, 750.42 / 261.27 px (Table 3)."""
    threads: int = 1
    """torch CPU threads."""

    def __post_init__(self):
        names = self.variants
        if not isinstance(names, list) or not names or len(set(names)) != len(names) \
                or not all(isinstance(n, str) for n in names):
            raise ValueError(f"variants must be a non-empty list of distinct names, got {names!r}")
        horizons = self.horizons
        if not isinstance(horizons, list) or not horizons or len(set(horizons)) != len(horizons) \
                or any(isinstance(h, bool) or not isinstance(h, int) or h < 1 for h in horizons):
            raise ValueError(f"horizons must be a non-empty list of distinct t_f >= 1, got "
                             f"{self.horizons!r}")
        if self.k < 1 or self.threads < 1:
            raise ValueError("k and threads must be >= 1")
        if self.split_for_choice not in ("train", "val"):
            raise ValueError(f"split_for_choice must be train or val (never test), got "
                             f"{self.split_for_choice!r}")
        if not 0 < self.target_fde_over_ade < float("inf"):
            raise ValueError(f"target_fde_over_ade must be a positive ratio, got "
                             f"{self.target_fde_over_ade}")


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


# ---------------------------------------------------------------------------------------------
# Short-term benchmarks


@dataclass(frozen=True)
class ShortTermParams:
    """Section `short_term` of params.yaml: the short-term windows and the ETH/UCY maps."""

    n_past: int = 8
    """Observed steps n_p (3.2 s at 2.5 FPS)."""
    n_future: int = 12
    """Predicted steps n_f (4.8 s); n_past + n_future = 20 is what the TrajNet SDD files hold."""
    fps: float = 2.5
    """Frame rate of the windows."""
    sdd_ratio_version: str = "A"
    """Row of `H_SDD.txt` (A or B) whose metres-per-pixel ratio converts TrajNet metres to pixels."""
    sdd_val_videos: list[str] = field(
        default_factory=lambda: ["bookstore_2", "deathCircle_3", "gates_8", "hyang_6", "nexus_7"])
    """Whole TrajNet train videos held out for model selection (never test videos)."""
    ethucy_folds: list[str] = field(default_factory=lambda: list(FOLD_TEST_SCENES))
    """Leave-one-scene-out folds to build (SGAN's folders)."""
    ethucy_min_agents: int = 2
    """A 20-frame run gives windows only if this many pedestrians are in all of it (SGAN: 2)."""
    ethucy_map_downsample: float = 1.5
    """The ETH/UCY maps are stored at 1 / this of the oracle's size (Y-net's ETH/UCY resize)."""

    def __post_init__(self) -> None:
        if self.n_past < 2 or self.n_future < 1:
            raise ValueError("n_past must be at least 2 and n_future at least 1")
        if self.fps <= 0 or (SDD_RAW_FPS / self.fps) % 1:
            raise ValueError(f"fps must divide SDD's {SDD_RAW_FPS} FPS, got {self.fps}")
        if self.sdd_ratio_version not in ("A", "B"):
            raise ValueError(f"sdd_ratio_version must be 'A' or 'B', got {self.sdd_ratio_version!r}")
        not_train = sorted(set(self.sdd_val_videos) - TRAIN_VIDEOS)
        if not_train:
            raise ValueError(f"sdd_val_videos must be TrajNet train videos; not train: {not_train}")
        unknown = sorted(set(self.ethucy_folds) - set(FOLD_TEST_SCENES))
        if unknown or not self.ethucy_folds or len(set(self.ethucy_folds)) < len(self.ethucy_folds):
            raise ValueError(f"ethucy_folds must be distinct folds of {sorted(FOLD_TEST_SCENES)}, "
                             f"got {self.ethucy_folds}")
        if self.ethucy_min_agents < 1:
            raise ValueError("ethucy_min_agents must be at least 1")
        if self.ethucy_map_downsample < 1:
            raise ValueError("ethucy_map_downsample must be at least 1")

    @property
    def window_length(self) -> int:
        return self.n_past + self.n_future

    @property
    def sdd_frame_step(self) -> int:
        """Raw SDD frames between two window steps (12 at 2.5 FPS)."""
        return int(SDD_RAW_FPS / self.fps)

    @property
    def ethucy_resize(self) -> float:
        return 1.0 / self.ethucy_map_downsample


DATASETS = ("sdd", *FOLD_TEST_SCENES)  # sdd, then the five ETH/UCY folds


# The short-term models (Tables 1 and 2), Y-net first: the keys of short_term_models.epochs.
MODELS = tuple(ours_first(SHORT_TERM_MODELS))


BENCHMARKS = ("sdd", "ethucy")


@dataclass
class YnetScale:
    """Y-net's map scale on one benchmark and the Gaussian ground truth that goes with it."""

    resize: float
    """Maps and coordinates relative to the original image (authors: SDD 0.25, ETH/UCY 1 / 1.5)."""
    kernel_size: int
    """Side of the Gaussian ground-truth kernel, pixels of the resized map (authors: 31)."""
    sigma: float
    """Its standard deviation, pixels of the resized map (authors: 4)."""
    crop: int = 0
    """Side of the window around each agent the model sees (`YnetSettings.crop`); 0 = whole scene."""
    crop_lead_steps: float = 0.0
    """The window is centred this many steps of the last observed velocity ahead of the agent."""

    def __post_init__(self):
        if not 0 < self.resize <= 1 or self.sigma <= 0 or self.kernel_size % 2 != 1:
            raise ValueError("need 0 < resize <= 1, sigma > 0 and an odd kernel_size")


@dataclass(frozen=True)
class YnetTraining:
    """How the short-term Y-net trains where it departs from `ynet.<profile>`
    (`YnetSettings` documents each; null = `ynet.<profile>`'s)."""

    learning_rate: float | None = None
    batch_size: int | None = None
    bf16: bool = False
    """bfloat16 autocast for the training forward passes on the CPU."""
    lr_schedule: str = "constant"
    """constant | cosine (to 0 over the run)."""
    trajectory_lr_scale: float | None = None
    """Factor on the trajectory decoder's learning rate; null (or absent) = one rate, as the authors."""
    grad_clip_norm: float | None = None
    """Clip each step's gradients to this global L2 norm; null (or absent) = no clipping, as the
    authors."""

    def __post_init__(self):
        if self.learning_rate is not None and self.learning_rate <= 0:
            raise ValueError(f"learning_rate must be positive or null, got {self.learning_rate}")
        if self.trajectory_lr_scale is not None and self.trajectory_lr_scale <= 0:
            raise ValueError(f"trajectory_lr_scale must be positive or null, got "
                             f"{self.trajectory_lr_scale}")
        if self.batch_size is not None and self.batch_size < 1:
            raise ValueError(f"batch_size must be positive or null, got {self.batch_size}")
        if self.grad_clip_norm is not None and self.grad_clip_norm < 0:
            raise ValueError(f"grad_clip_norm must be >= 0 or null, got {self.grad_clip_norm}")

    def overrides(self) -> dict:
        """The `YnetSettings` fields this section sets."""
        return {key: value for key, value in dataclasses.asdict(self).items() if value is not None}


@dataclass(frozen=True)
class YnetTrainingByBenchmark:
    """`YnetTraining` for each short-term benchmark: a departure chosen on one benchmark's
    validation windows need not help the other (SDD in pixels, ETH/UCY's folds in metres)."""

    sdd: YnetTraining
    ethucy: YnetTraining

    def of(self, benchmark: str) -> YnetTraining:
        if benchmark not in BENCHMARKS:
            raise ValueError(f"unknown benchmark {benchmark!r}; known: {list(BENCHMARKS)}")
        return getattr(self, benchmark)


@dataclass
class ShortTermModelsParams:
    """Section `short_term_models.<profile>` of params.yaml."""

    epochs: dict[str, dict[str, int]]
    """Model (ynet, sgan, pecnet) -> benchmark (sdd, ethucy: each fold) -> training epochs."""
    ynet_steps_per_epoch: int
    """Y-net optimiser steps per epoch, about (windows drawn afresh each epoch); 0 = every window."""
    ynet_training: YnetTrainingByBenchmark
    """How Y-net trains on each benchmark, where it departs from `ynet.<profile>` (the long-term
    model's)."""
    val_windows: int
    """Validation windows that select the epoch (a fixed seeded sample); 0 = all of them."""
    ynet_sdd: YnetScale
    ynet_ethucy: YnetScale
    ynet_datasets: list[str]
    """Datasets this profile trains and scores Y-net on; any other gets a not-run record."""
    why_subset: str
    """Shown in the report for a dataset outside `ynet_datasets`."""
    temperature: float
    """TTST temperature of the short-term setting (authors: 1.0)."""
    rel_threshold: dict[str, float]
    """Benchmark (sdd, ethucy) -> TTST: goal pixels below rel_threshold * max are never sampled
    (authors: 0.01 on both)."""
    k_sdd: list[int]
    """K values scored on SDD (Table 1: 20 and 5)."""
    k_ethucy: list[int]
    """K values scored on ETH/UCY (Table 2: 20)."""
    rounds: int
    """Seeded evaluation rounds; mean and spread are reported."""
    seed: int
    """Round r samples with seed + r; also draws the validation sample."""
    eval_batch_size: int
    """Y-net: test windows per forward pass (one scene per batch)."""
    eval_chunk_size: int
    """Y-net: samples per window decoded together by the trajectory decoder."""
    eval_threads: int
    """Y-net: torch CPU threads for scoring (training's: `ynet.<profile>.threads`)."""
    bf16: bool
    """Y-net: bfloat16 autocast for the trajectory decoder (`ynet.sampling.predict`)."""

    def __post_init__(self):
        if set(self.epochs) != set(MODELS) or any(
                set(e) != set(BENCHMARKS) or min(e.values()) < 1 for e in self.epochs.values()):
            raise ValueError(f"epochs must give every model {list(MODELS)} positive epochs for "
                             f"each of {list(BENCHMARKS)}, got {self.epochs}")
        if self.ynet_steps_per_epoch < 0 or self.val_windows < 0:
            raise ValueError("ynet_steps_per_epoch and val_windows must be >= 0 (0 = all)")
        unknown = sorted(set(self.ynet_datasets) - set(DATASETS))
        if unknown:
            raise ValueError(f"ynet_datasets: unknown dataset(s) {unknown}; known: {list(DATASETS)}")
        if not self.k_sdd or not self.k_ethucy or min(self.k_sdd + self.k_ethucy) < 1:
            raise ValueError("k_sdd and k_ethucy must be non-empty lists of positive K")
        if (self.rounds < 1 or self.temperature <= 0 or set(self.rel_threshold) != set(BENCHMARKS)
                or not all(0 <= value < 1 for value in self.rel_threshold.values())):
            raise ValueError(f"need rounds >= 1, temperature > 0 and 0 <= rel_threshold < 1 for each "
                             f"of {list(BENCHMARKS)}, got rel_threshold {self.rel_threshold}")
        if min(self.eval_batch_size, self.eval_chunk_size, self.eval_threads) < 1:
            raise ValueError("eval_batch_size, eval_chunk_size and eval_threads must be positive")

    def eval_params(self) -> EvalParams:
        """What `evaluate_ynet.predict_scenes` reads (seeds are passed per round)."""
        return EvalParams(k_e=max(self.k_sdd + self.k_ethucy), k_a=1, rounds=self.rounds,
                          seed=self.seed, batch_size=self.eval_batch_size,
                          chunk_size=self.eval_chunk_size, bf16=self.bf16)


# ---------------------------------------------------------------------------------------------
# inD and the report


@dataclass(frozen=True)
class IndBenchmarkParams:
    """Section `ind_benchmark.<profile>` of params.yaml: what differs on inD from SDD."""

    ynet_resize: float
    """Y-net's map and coordinate scale on inD backgrounds (authors: 0.33; SDD 0.25)."""
    segmentation_downsample: int
    """The U-Net sees inD backgrounds downsampled by this factor (paper: 3; SDD 4)."""
    freeze_encoder_epochs: int
    """Fine-tuning epochs (of `segmentation.<profile>.epochs`) with the U-Net encoder frozen."""

    def __post_init__(self) -> None:
        if not 0 < self.ynet_resize <= 1:
            raise ValueError(f"ynet_resize must be in (0, 1], got {self.ynet_resize}")
        if self.segmentation_downsample < 1 or self.freeze_encoder_epochs < 0:
            raise ValueError("need segmentation_downsample >= 1 and freeze_encoder_epochs >= 0")


@dataclass
class ReportParams:
    close: float
    """|ours - paper| / paper at or below this is shown green ("reproduced")."""
    far: float
    """Above this it is red; amber between `close` and `far`."""

    def __post_init__(self):
        if not 0 <= self.close < self.far:
            raise ValueError(f"need 0 <= close < far, got close={self.close}, far={self.far}")
