"""params.yaml must validate against every stage's dataclass; typos must fail loudly."""

from dataclasses import dataclass, field

import pytest

from pipeline.config import CompatParams, CwsParams, EvalParams, FetchParams, HorizonParams, LabelsParams, ParamsError, ReportParams, SegmentationParams, SemanticParams, SplitParams, TtstParams, WindowParams, from_dict, load_section, read_params
from pipeline.config import load_profile
from pipeline.runners.ynet_training import YnetSettings

SECTIONS = {"fetch": FetchParams, "compat": CompatParams, "split": SplitParams,
            "windows": WindowParams, "report": ReportParams, "labels": LabelsParams,
            "semantic": SemanticParams}


@pytest.mark.parametrize("key, cls", SECTIONS.items())
def test_params_yaml_sections_validate(key, cls):
    load_section(cls, key, read_params())


PROFILED = {"ynet": YnetSettings, "eval": EvalParams, "segmentation": SegmentationParams,
            "ynet_horizons": HorizonParams}


@pytest.mark.parametrize("profile", ["cpu", "paper"])
@pytest.mark.parametrize("key, cls", PROFILED.items())
def test_profiled_sections_validate_for_both_profiles(key, cls, profile):
    params = {**read_params(), "profile": profile}
    load_profile(cls, key, params)


def test_sampling_sections_validate():
    params = read_params()
    load_section(TtstParams, "ttst", params)
    load_section(CwsParams, "cws", params)


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
