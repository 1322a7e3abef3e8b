"""Floats written as YAML 1.2 writes them (`1e9`, `1e-3`: no dot, or an unsigned exponent) reach a
float param as numbers: DVC (ruamel, YAML 1.2) reads them so, PyYAML (YAML 1.1) as strings, and a
`dvc exp run -S ttst.temperature=1e9` (or a hand edit) must meet the param's own range check, not
"expected float, got str"."""

import pytest
import yaml

from pipeline.config.loading import ParamsError, from_dict, load_section, yaml12_floats
from pipeline.config.sgan import SganConfig
from pipeline.config.ttst import TtstParams


def test_pyyaml_reads_these_as_strings_and_dvc_as_numbers():
    """Why the params need it: the two parsers of the same params.yaml disagree."""
    from dvc.utils.serialize._yaml import parse_yaml

    text = "ttst:\n  temperature: 1e9\n  rel_threshold: 1e-3\n"
    assert yaml.safe_load(text)["ttst"] == {"temperature": "1e9", "rel_threshold": "1e-3"}
    assert parse_yaml(text, "params.yaml")["ttst"] == {"temperature": 1e9, "rel_threshold": 1e-3}


def test_a_yaml12_float_reaches_a_float_param_as_a_number():
    params = yaml.safe_load("ttst:\n  temperature: 1e9\n  rel_threshold: 1e-3\n")
    assert load_section(TtstParams, "ttst", params) == TtstParams(temperature=1e9,
                                                                  rel_threshold=1e-3)


@pytest.mark.parametrize("text, match", [
    ("{temperature: -1e9, rel_threshold: 0.002}", "temperature must be > 0, got -1000000000.0"),
    ("{temperature: 1.8, rel_threshold: 1E+1}", r"rel_threshold must be in \[0, 1\), got 10.0"),
])
def test_out_of_range_it_meets_the_range_check(text, match):
    with pytest.raises(ParamsError, match=match):
        from_dict(TtstParams, yaml.safe_load(text), "params.yaml:ttst")


def test_only_numbers_and_only_where_a_float_is_wanted():
    assert yaml12_floats(float, "1e9") == 1e9 and yaml12_floats(float | None, ".5e1") == 5.0
    assert yaml12_floats(str, "1e9") == "1e9"  # a string param keeps its text
    assert yaml12_floats(str | float, "1e9") == "1e9"  # either: YAML said string
    for not_a_number in ("1e", "e9", "1e9x", "1_000", "nan", "0x10", ""):
        assert yaml12_floats(float, not_a_number) == not_a_number
    with pytest.raises(ParamsError, match="expected float, got str 'fast'"):
        from_dict(TtstParams, {"temperature": "fast"}, "ttst")


def test_lists_and_mappings_of_floats_take_them_too():
    assert yaml12_floats(list[float], ["1e-1", 2]) == [0.1, 2]
    assert yaml12_floats(dict[str, float], {"eth": "2e-1"}) == {"eth": 0.2}
    sgan = from_dict(SganConfig, yaml.safe_load("learning_rate: 3e-4\nreal_label: [7e-1, 1.2]"),
                     "params.yaml:sgan.cpu")
    assert (sgan.learning_rate, sgan.real_label) == (3e-4, [0.7, 1.2])
