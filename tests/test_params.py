"""params.yaml must validate against every stage's dataclass; typos must fail loudly."""

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from pipeline.config.baseline_seeds import BaselineSeedsParams
from pipeline.config.compat import CompatParams
from pipeline.config.cws import CwsParams
from pipeline.config.data import DataParams
from pipeline.config.eval import EvalParams
from pipeline.config.fetch import FetchParams
from pipeline.config.labels import LabelsParams
from pipeline.config.loading import (ParamsError, from_dict, load_profile, load_section,
                                     read_params)
from pipeline.config.pecnet import PecnetConfig
from pipeline.config.pecnet_test_selection import PecnetTestSelectionParams
from pipeline.config.report import ReportParams
from pipeline.config.rpecnet_rollouts import RpecnetRolloutsParams
from pipeline.config.score_predictions import ScorePredictionsParams
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.semantic import SemanticParams
from pipeline.config.sgan import SganConfig
from pipeline.config.split import SplitParams
from pipeline.config.ttst import TtstParams
from pipeline.config.windows import WindowParams
from pipeline.config.ynet import YnetSettings
from pipeline.config.ynet_horizons import HorizonParams
from pipeline.config.ynet_seeds import YnetSeedsParams

SECTIONS = {"fetch": FetchParams, "compat": CompatParams, "split": SplitParams,
            "windows": WindowParams, "report": ReportParams, "labels": LabelsParams,
            "semantic": SemanticParams, "data": DataParams,
            "score_predictions": ScorePredictionsParams,
            "baseline_seeds": BaselineSeedsParams, "rpecnet_rollouts": RpecnetRolloutsParams,
            "pecnet_test_selection": PecnetTestSelectionParams}


def plain(value):
    """Tuples as lists and mapping keys as strings, as JSON has them, to compare yaml with objects."""
    return json.loads(json.dumps(value, default=list))


def assert_holds(loaded, cls, raw: dict) -> None:
    """`loaded` is a `cls` whose every field named in the yaml section `raw` has the yaml value."""
    assert isinstance(loaded, cls), type(loaded)
    fields = plain(dataclasses.asdict(loaded))
    assert raw, "an empty section proves nothing"
    for key, value in raw.items():
        assert fields[str(key)] == plain(value), key


def test_ttst_has_no_default_beside_params_yaml():
    """params.yaml is the one place of the TTST settings: a key missing there is an error, not the
    authors' value taken silently."""
    for missing in ("temperature", "rel_threshold"):
        section = {key: value for key, value in read_params()["ttst"].items() if key != missing}
        with pytest.raises(ParamsError, match=rf"params.yaml:ttst: missing key\(s\) \['{missing}'\]"):
            load_section(TtstParams, "ttst", {"ttst": section})


@pytest.mark.parametrize("key, cls", SECTIONS.items())
def test_params_yaml_sections_validate(key, cls):
    params = read_params()
    assert_holds(load_section(cls, key, params), cls, params[key])


PROFILED = {"ynet": YnetSettings, "eval": EvalParams, "segmentation": SegmentationParams,
            "ynet_horizons": HorizonParams, "ynet_seeds": YnetSeedsParams, "sgan": SganConfig,
            "pecnet": PecnetConfig}


@pytest.mark.parametrize("profile", ["cpu", "paper"])
@pytest.mark.parametrize("key, cls", PROFILED.items())
def test_profiled_sections_validate_for_both_profiles(key, cls, profile):
    params = {**read_params(), "profile": profile}
    assert_holds(load_profile(cls, key, params), cls, params[key][profile])


def test_sampling_sections_validate():
    params = read_params()
    assert_holds(load_section(TtstParams, "ttst", params), TtstParams, params["ttst"])
    assert_holds(load_section(CwsParams, "cws", params), CwsParams, params["cws"])


@dataclass
class Inner:
    rate: float = 1.0


@dataclass
class Outer:
    name: str
    inner: Inner = field(default_factory=Inner)


def test_unknown_key_fails():
    with pytest.raises(ParamsError, match=r"unknown key\(s\) \['nmae'\]"):
        from_dict(Outer, {"nmae": "x"}, "here")


def test_missing_key_fails():
    with pytest.raises(ParamsError, match=r"missing key\(s\) \['name'\]"):
        from_dict(Outer, {}, "here")


def test_nested_sections_are_typed():
    outer = from_dict(Outer, {"name": "a", "inner": {"rate": 2.0}}, "here")
    assert outer.inner == Inner(rate=2.0)
    with pytest.raises(ParamsError, match=r"here.inner: unknown key"):
        from_dict(Outer, {"name": "a", "inner": {"rat": 2.0}}, "here")


def test_post_init_checks_surface_as_params_errors():
    with pytest.raises(ParamsError, match="not train"):
        from_dict(SplitParams, {"val_videos": ["gates_2"]}, "split")
    with pytest.raises(ParamsError, match="not a multiple"):
        from_dict(WindowParams, {"raw_fps": 30, "target_fps": 7}, "windows")
    with pytest.raises(ParamsError, match="not a folder path or an http"):
        from_dict(FetchParams, {"locations": ["ftp://x"]}, "fetch")


@pytest.mark.parametrize("values, match", [
    ({"miss_threshold_m": 0.0}, "miss_threshold_m must be a positive distance"),
    ({"collision_threshold_m": -0.2}, "collision_threshold_m must be a positive distance"),
    ({"log_pdf_floor": 5.0}, "log_pdf_floor must be a finite negative"),
    ({"forbidden_classes": []}, "forbidden_classes must be a non-empty list"),
    ({"forbidden_classes": ["tree", "tree"]}, "distinct class names"),
])
def test_score_predictions_thresholds_are_checked(values, match):
    with pytest.raises(ParamsError, match=match):
        from_dict(ScorePredictionsParams, values, "score_predictions")


@pytest.mark.parametrize("values, match", [
    ({"split_for_choice": "test"}, "never test"),
    ({"variants": []}, "variants must be a non-empty list"),
    ({"variants": ["independent", "independent"]}, "distinct names"),
    ({"horizons": [30, 0]}, "horizons must be a non-empty list"),
    ({"target_fde_over_ade": 0.0}, "positive ratio"),
])
def test_rpecnet_rollouts_settings_are_checked(values, match):
    with pytest.raises(ParamsError, match=match):
        from_dict(RpecnetRolloutsParams, values, "rpecnet_rollouts")


@pytest.mark.parametrize("name", ["params.yaml", "dvc.yaml", "dvc.lock"])
def test_dvc_reads_the_project_yaml_as_pyyaml_does(name):
    """DVC parses these with ruamel.yaml, which uses libyaml (ruamel.yaml.clib) when installed:
    stricter than the pure parser (an unquoted URL inside a flow mapping `{..., base: https://...}`
    is an error there, and `dvc status` then calls the file corrupted)."""
    import yaml
    from dvc.utils.serialize._yaml import parse_yaml
    from ruamel.yaml.main import CParser

    assert CParser is not None, "ruamel.yaml.clib is missing: pyproject.toml pins it"
    text = (Path(__file__).resolve().parents[1] / name).read_text()
    assert parse_yaml(text, name) == yaml.load(text, Loader=yaml.CSafeLoader)
