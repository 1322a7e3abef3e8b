"""`runtime.device`: names, resolution, each purpose's CUDA settings and the CPU helpers being
identities."""

import os

import pytest
import torch

import pipeline.device
from pipeline.config.loading import ParamsError, load_section
from pipeline.config.runtime import RuntimeParams, parse_device_name
from pipeline.config.ynet import YnetSettings
from pipeline.device import (SCORING, TRAINING, adam_options, autocast, conv_layout, cpu_has_bf16,
                             generator, resolve_device, select_device, to_device, use_bf16)
from pipeline.runners.ynet_training import optimizer_groups, ynet_optimizer
from ynet.model import YNet


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


def torch_settings() -> dict:
    """The process-wide switches `select_device` may set."""
    return {"benchmark": torch.backends.cudnn.benchmark,
            "cudnn deterministic": torch.backends.cudnn.deterministic,
            "deterministic algorithms": torch.are_deterministic_algorithms_enabled(),
            "warn only": torch.is_deterministic_algorithms_warn_only_enabled(),
            "matmul tf32": torch.backends.cuda.matmul.allow_tf32,
            "cudnn tf32": torch.backends.cudnn.allow_tf32,
            "cublas workspace": os.environ.get("CUBLAS_WORKSPACE_CONFIG"),
            "fill uninitialized": torch.utils.deterministic.fill_uninitialized_memory}


@pytest.fixture
def restored_settings(monkeypatch):
    """The switches as they were after the test; CUBLAS_WORKSPACE_CONFIG through monkeypatch."""
    monkeypatch.delenv("CUBLAS_WORKSPACE_CONFIG", raising=False)
    before = torch_settings()
    yield before
    torch.backends.cudnn.benchmark = before["benchmark"]
    torch.backends.cudnn.deterministic = before["cudnn deterministic"]
    torch.use_deterministic_algorithms(before["deterministic algorithms"], warn_only=before["warn only"])
    torch.backends.cuda.matmul.allow_tf32 = before["matmul tf32"]
    torch.backends.cudnn.allow_tf32 = before["cudnn tf32"]
    torch.utils.deterministic.fill_uninitialized_memory = before["fill uninitialized"]


def test_training_autotunes_and_scoring_stays_deterministic_on_cuda(monkeypatch, restored_settings):
    """Training may use any cuDNN algorithm (it repeats only up to rounding on CUDA anyway);
    scoring keeps deterministic algorithms, so scoring a checkpoint twice gives the same numbers."""
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    monkeypatch.setattr(torch.cuda, "current_device", lambda: 0)
    monkeypatch.setattr(torch.cuda, "set_device", lambda device: None)
    assert select_device("cuda", purpose=TRAINING) == torch.device("cuda", 0)
    training = torch_settings()
    del training["warn only"]  # meaningless with deterministic algorithms off
    assert training == {"benchmark": True, "cudnn deterministic": False,
                        "deterministic algorithms": False, "matmul tf32": True, "cudnn tf32": True,
                        "cublas workspace": None, "fill uninitialized": False}
    select_device("cuda", purpose=SCORING)
    assert torch_settings() == {"benchmark": False, "cudnn deterministic": True,
                                "deterministic algorithms": True, "warn only": True,
                                "matmul tf32": True, "cudnn tf32": True,
                                "cublas workspace": ":4096:8", "fill uninitialized": False}
    select_device("cuda", purpose=TRAINING)  # one process may measure both (bench_profiles)
    assert not torch.backends.cudnn.deterministic and torch.backends.cudnn.benchmark


def test_on_the_cpu_no_purpose_changes_a_setting(restored_settings):
    for purpose in (TRAINING, SCORING):
        assert select_device("cpu", purpose=purpose) == torch.device("cpu")
        assert torch_settings() == restored_settings


def test_a_purpose_must_be_named_and_known():
    with pytest.raises(TypeError):
        select_device("cpu")
    with pytest.raises(ValueError, match="purpose"):
        select_device("cpu", purpose="evaluation")


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


def test_adam_is_fused_on_cuda_and_as_it_was_on_the_cpu():
    """Training's optimiser (`ynet_training.ynet_optimizer`) asks for the fused step on CUDA; on
    the CPU it is the plain Adam of before, state and hyperparameters alike."""
    assert adam_options(torch.device("cuda", 0)) == {"fused": True}
    assert adam_options(torch.device("cpu")) == {}
    settings = YnetSettings(resize=0.25, epochs=1, batch_size=2, learning_rate=1e-3,
                            augmentations=1, kernel_size=7, sigma=1.5, waypoints=[1, 3],
                            encoder_channels=[4, 4, 8, 8, 8], decoder_channels=[8, 8, 8, 4, 4],
                            seed=0, threads=1, trajectory_lr_scale=2.0)
    model = YNet(settings.model_config(3, 4))
    on_cuda = ynet_optimizer(model, settings, torch.device("cuda", 0))  # built on the CPU's params
    assert [group["fused"] for group in on_cuda.param_groups] == [True, True]
    on_cpu = ynet_optimizer(model, settings, torch.device("cpu"))
    plain = torch.optim.Adam(optimizer_groups(model, settings), lr=settings.learning_rate)
    assert on_cpu.state_dict() == plain.state_dict()
    assert [group["fused"] for group in on_cpu.param_groups] == [None, None]


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
