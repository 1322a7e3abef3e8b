"""Where torch runs: one place that turns params.yaml `runtime.device` into a device and its habits.

Every training and scoring stage calls `select_device` once, naming its purpose, and then only uses
the helpers below, so no other module needs to know whether it runs on a CPU or a GPU:

- `select_device("auto")` is CUDA when one is available, else the CPU; "cpu", "cuda" and "cuda:N"
  ask for exactly that and fail with a clear message when it is not there.
- On CUDA it turns on TF32 matmuls and convolutions, and what its `purpose` wants: `SCORING`
  deterministic algorithms where CUDA has them (`torch.use_deterministic_algorithms(warn_only=True)`;
  see `NONDETERMINISTIC_ON_CUDA`; uninitialised memory left unfilled), so scoring a checkpoint
  repeats; `TRAINING` cuDNN's autotuner and
  its fastest algorithms, deterministic or not, since a CUDA training run repeats only up to
  rounding anyway (the upsampling's backward) and deterministic cuDNN gives up the fast
  weight-gradient kernels.
- `autocast(device)` is bfloat16 autocast on CUDA (convolutions and matmuls; losses, softmaxes and
  sampling stay float32, as autocast keeps them), and nothing on the CPU, whose `cpu` profile
  numbers must not move. Stages that chose CPU bf16 on purpose pass `cpu_bf16=True`; it takes
  effect only on a CPU with bf16 hardware (`use_bf16`), float32 elsewhere.
- `to_device` pins host memory and copies without blocking on CUDA; on the CPU it returns the
  tensor itself.
- `adam_options(device)`: fused Adam on CUDA, the plain one on the CPU.
- `generator(device, seed)`: random draws are made on the device their tensors live on.
- `rng_states` / `restore_rng_states`: torch's global RNG states (and CUDA's) in a checkpoint.

On the CPU nothing here changes a single number: the helpers are identities there.
"""

from __future__ import annotations

import contextlib
import os
import sys

import torch

from pipeline.config.runtime import parse_device_name

CPU = torch.device("cpu")

# The op our models use whose CUDA kernel has no deterministic version (PyTorch 2.x, checked
# against `torch.use_deterministic_algorithms`' list): under `SCORING`'s `warn_only=True` it would
# run anyway and warn once. So on one GPU, training with one seed repeats up to float rounding in
# the decoders' gradients, not bit for bit, whatever the settings (`TRAINING` does not try);
# scoring (forward passes, seeded sampling on the device) repeats.
# S-GAN's pooling (`scatter_reduce` "amax") and the U-Net's IoU (`bincount` without weights) have
# deterministic results however their threads are ordered.
NONDETERMINISTIC_ON_CUDA = (
    "upsample_bilinear2d backward: the x2 bilinear upsampling of the Y-net and U-Net decoders "
    "(training only)",
)


def resolve_device(name: str) -> torch.device:
    """The torch.device a `runtime.device` name stands for on this machine."""
    kind, index = parse_device_name(name)
    if kind == "cpu" or (kind == "auto" and not torch.cuda.is_available()):
        return CPU
    if not torch.cuda.is_available():
        raise RuntimeError(f"runtime.device is {name!r} but torch sees no CUDA device "
                           f"(torch {torch.__version__}, built for CUDA {torch.version.cuda}); "
                           "use 'auto' or 'cpu'")
    if index is not None and index >= torch.cuda.device_count():
        raise RuntimeError(f"runtime.device is {name!r} but only {torch.cuda.device_count()} CUDA "
                           "device(s) are visible")
    return torch.device("cuda", index if index is not None else torch.cuda.current_device())


TRAINING = "training"
"""A stage that trains: cuDNN autotuning and non-deterministic algorithms (hardware speed)."""
SCORING = "scoring"
"""A stage that only runs trained models: deterministic algorithms, so its numbers repeat."""


def select_device(name: str, *, purpose: str) -> torch.device:
    """`resolve_device`, then the CUDA settings of `purpose` (`TRAINING` or `SCORING`); the CPU's
    are left alone."""
    if purpose not in (TRAINING, SCORING):
        raise ValueError(f"purpose must be {TRAINING!r} or {SCORING!r}, got {purpose!r}")
    device = resolve_device(name)
    if device.type == "cuda":
        torch.cuda.set_device(device)
        torch.backends.cuda.matmul.allow_tf32 = True
        torch.backends.cudnn.allow_tf32 = True
        repeatable = purpose == SCORING
        if repeatable:
            # cuBLAS needs this before its first call to pick deterministic reductions.
            os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
        torch.backends.cudnn.benchmark = not repeatable  # autotuned per input shape
        torch.backends.cudnn.deterministic = repeatable
        torch.use_deterministic_algorithms(repeatable, warn_only=True)
        # With deterministic algorithms on, torch also fills every uninitialised tensor with NaN
        # (one kernel each: about 51,000 of scoring's 163,000 launches for 32 windows on an H200
        # before issue 62). No op of ours reads memory it has not written, so the results do not
        # depend on that fill; `bench/gpu_check.py` scores twice and compares to show it.
        torch.utils.deterministic.fill_uninitialized_memory = False
    return device


def describe(device: torch.device) -> str:
    """A line for logs and metrics: which device, and what it is."""
    if device.type == "cuda":
        return f"{device} ({torch.cuda.get_device_name(device)})"
    return f"cpu ({torch.get_num_threads()} threads)"


def cpu_has_bf16() -> bool:
    """Whether this CPU does bfloat16 arithmetic in hardware (AVX-512 BF16 or AMX tiles).

    Elsewhere torch emulates it: on an AVX2-only AMD EPYC (2026-11-26) a 3 x 3 convolution
    (8 x 32 x 128 x 128) took 3.59 s under CPU bf16 autocast against 0.036 s in float32, so the
    `cpu` profile's segmentation would have taken 5.4 h instead of minutes.
    """
    return torch.cpu._is_avx512_bf16_supported() or torch.cpu._is_amx_tile_supported()


_told_float32 = False


def use_bf16(device: torch.device, requested: bool) -> bool:
    """Whether a bfloat16 choice runs as bfloat16 here: always on CUDA; on the CPU when a profile
    asks for it (`requested`) and the CPU has bf16 hardware (`cpu_has_bf16`), else float32 with a
    notice on stderr, once per process (the numbers are then those of float32)."""
    global _told_float32
    if device.type == "cuda":
        return True
    if requested and not cpu_has_bf16():
        if not _told_float32:
            print("note: params ask for bfloat16 on the CPU, but this CPU has no bf16 hardware "
                  "(AVX-512 BF16 or AMX), where torch emulates it about 100x slower: running float32",
                  file=sys.stderr)
            _told_float32 = True
        return False
    return requested


AUTOCAST_DTYPE = torch.bfloat16
"""What `autocast` runs convolutions and matmuls in."""


def autocast(device: torch.device, cpu_bf16: bool = False):
    """bfloat16 autocast on CUDA; on the CPU only when `cpu_bf16` (a profile's explicit choice)
    and the CPU has bf16 hardware (`use_bf16`)."""
    if device.type == "cuda":
        return torch.autocast("cuda", dtype=AUTOCAST_DTYPE)
    if use_bf16(device, cpu_bf16):
        return torch.autocast("cpu", dtype=AUTOCAST_DTYPE)
    return contextlib.nullcontext()


def to_device(tensor: torch.Tensor, device: torch.device) -> torch.Tensor:
    """`tensor` on `device`: pinned and non-blocking to CUDA; the very same tensor on the CPU."""
    if tensor.device == device:
        return tensor
    if device.type == "cuda" and tensor.device.type == "cpu":
        return tensor.pin_memory().to(device, non_blocking=True)
    return tensor.to(device)


def generator(device: torch.device, seed: int) -> torch.Generator:
    """A seeded generator on `device`, so draws happen where the tensors they index live."""
    return torch.Generator(device=device).manual_seed(seed)


def module_device(module: torch.nn.Module) -> torch.device:
    """The device a module's parameters live on (where its inputs must go)."""
    return next(module.parameters()).device


def rng_states(device: torch.device) -> dict[str, torch.Tensor]:
    """torch's global RNG state, and the device's own on CUDA: what a checkpoint keeps to resume."""
    states = {"torch": torch.get_rng_state()}
    if device.type == "cuda":
        states["cuda"] = torch.cuda.get_rng_state(device)
    return states


def restore_rng_states(states: dict[str, torch.Tensor] | None, device: torch.device) -> None:
    """Undo `rng_states`, wherever the checkpoint's tensors were loaded to (the CUDA state only
    when resuming on CUDA); None or {} (an older checkpoint without them): nothing."""
    if not states:
        return
    torch.set_rng_state(states["torch"].cpu())
    if device.type == "cuda" and "cuda" in states:
        torch.cuda.set_rng_state(states["cuda"].cpu(), device)


def adam_options(device: torch.device) -> dict:
    """Keyword arguments of `torch.optim.Adam` for parameters on `device`: fused on CUDA (one
    kernel for the whole step instead of several per parameter: Adam's step was 7.7 % of a `paper`
    Y-net training step's kernel time on an H200, unfused); none on the CPU, whose optimiser, and
    so its numbers and checkpoints, stay as they were."""
    return {"fused": True} if device.type == "cuda" else {}


def conv_layout(module: torch.nn.Module, device: torch.device) -> torch.nn.Module:
    """`module` on `device`, channels-last on CUDA (tensor cores want NHWC); unchanged on CPU."""
    module = module.to(device)
    if device.type == "cuda":
        module = module.to(memory_format=torch.channels_last)
    return module


def synchronize(device: torch.device) -> None:
    """Wait for queued GPU work (before reading a clock); nothing on the CPU."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)
