"""Fixtures shared by several test files."""

import pytest

import pipeline.device


@pytest.fixture
def cpu_bf16_hardware():
    """Run the CPU bfloat16 paths as on a CPU with bf16 hardware, whatever this one has: where it
    has none, `pipeline.device.use_bf16` would fall back to float32 and the test would check nothing.
    Emulated bf16 is slow, but fine at test sizes. A patch of its own, so a test's
    `monkeypatch.undo()` leaves it in place."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(pipeline.device, "cpu_has_bf16", lambda: True)
        yield
