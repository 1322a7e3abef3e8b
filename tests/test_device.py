"""`runtime.device`: names, resolution and the CPU helpers being identities."""

import pytest
import torch

import pipeline.device
from pipeline.device import (autocast, conv_layout, cpu_has_bf16, generator, resolve_device,
                             to_device, use_bf16)
from pipeline.config import ParamsError, RuntimeParams, load_section, parse_device_name


@pytest.mark.parametrize("name, parsed", [("auto", ("auto", None)), ("cpu", ("cpu", None)),
                                          ("cuda", ("cuda", None)), ("cuda:1", ("cuda", 1))])
def test_device_names(name, parsed):
    assert parse_device_name(name) == parsed


@pytest.mark.parametrize("name", ["gpu", "cuda:", "cuda:x", "CPU", "mps:0", ""])
def test_bad_device_names_are_errors(name):
    with pytest.raises(ValueError, match="auto, cpu, cuda or cuda:N"):
        parse_device_name(name)
    with pytest.raises(ParamsError, match="runtime"):
        load_section(RuntimeParams, "runtime", {"runtime": {"device": name}})


def test_auto_is_cuda_only_when_available_and_cpu_is_cpu():
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert resolve_device("auto").type == expected
    assert resolve_device("cpu") == torch.device("cpu")


def test_auto_names_the_current_cuda_device_by_index(monkeypatch):
    # `torch.cuda.set_device` rejects a CUDA device without an index, and `select_device` calls
    # it: an index-less "auto" crashed every stage on the first real GPU.
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 2)
    monkeypatch.setattr(torch.cuda, "current_device", lambda: 1)
    assert resolve_device("auto") == torch.device("cuda", 1)
    assert resolve_device("cuda") == torch.device("cuda", 1)
    assert resolve_device("cuda:0") == torch.device("cuda", 0)


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has CUDA")
def test_asking_for_cuda_without_one_says_so():
    with pytest.raises(RuntimeError, match="no CUDA device"):
        resolve_device("cuda:0")


def test_cpu_helpers_change_nothing():
    cpu = torch.device("cpu")
    x = torch.randn(3, 4)
    assert to_device(x, cpu) is x
    module = torch.nn.Conv2d(2, 2, 3)
    weight = module.weight.clone()
    assert conv_layout(module, cpu) is module and torch.equal(module.weight, weight)
    assert module.weight.is_contiguous()  # channels-last is for CUDA only
    with autocast(cpu):
        assert (x @ x.T).dtype == torch.float32
    with autocast(cpu, cpu_bf16=True):  # a profile's choice, where the CPU has bf16 hardware
        assert (x @ x.T).dtype == (torch.bfloat16 if cpu_has_bf16() else torch.float32)
    assert torch.equal(torch.rand(5, generator=generator(cpu, 3)),
                       torch.rand(5, generator=torch.Generator().manual_seed(3)))


def test_max_minutes_must_not_be_negative():
    with pytest.raises(ParamsError, match="max_minutes"):
        load_section(RuntimeParams, "runtime", {"runtime": {"max_minutes": -1}})


@pytest.mark.parametrize("hardware", [True, False])
def test_cpu_bf16_runs_only_on_bf16_hardware(monkeypatch, capsys, hardware):
    """Emulated bf16 is about 100x slower than float32 on an AVX2-only CPU: fall back, and say so."""
    monkeypatch.setattr(pipeline.device, "cpu_has_bf16", lambda: hardware)
    monkeypatch.setattr(pipeline.device, "_told_float32", False)
    cpu, x = torch.device("cpu"), torch.randn(3, 4)
    assert use_bf16(cpu, requested=True) is hardware
    assert use_bf16(cpu, requested=False) is False
    assert use_bf16(torch.device("cuda"), requested=False) is True  # CUDA always runs bf16
    with autocast(cpu, cpu_bf16=True):
        assert (x @ x.T).dtype == (torch.bfloat16 if hardware else torch.float32)
    notice = capsys.readouterr().err
    assert ("no bf16 hardware" in notice) is (not hardware)
    assert notice.count("note:") <= 1  # once per process
