"""Y-net's training inputs on a GPU: padding by slices and crops by one gather (no boolean masks,
no host reads), bit for bit what the masks and the per-agent loop made before (the references
below)."""

import pytest
import torch
import torch.nn.functional as F

from pipeline.data.ynet_data import agent_crops, pad_to_multiple, padded_semantic

# The inputs as they were: padding by boolean masks, crops one agent at a time.

def reference_padded_semantic(semantic, padding_class):
    padded = pad_to_multiple(semantic)
    height, width = semantic.shape[-2:]
    outside = torch.ones(padded.shape[-2:], dtype=torch.bool)
    outside[:height, :width] = False
    padded[padding_class][outside] = 1.0
    return padded


def reference_agent_crops(semantic, centres, size, padding_class):
    _, height, width = semantic.shape
    half = size // 2
    padded = F.pad(semantic, (half, size, half, size))
    outside = torch.ones(padded.shape[-2:], dtype=torch.bool)
    outside[half:half + height, half:half + width] = False
    padded[padding_class][outside] = 1.0
    origin = torch.round(centres).long() - half
    origin[:, 0].clamp_(-half, width)
    origin[:, 1].clamp_(-half, height)
    crops = torch.stack([padded[:, y + half:y + half + size, x + half:x + half + size]
                         for x, y in origin.tolist()])
    return crops, origin.to(centres.dtype)


@pytest.mark.parametrize("height, width", [(40, 70), (64, 96), (33, 31)])
def test_padding_and_crops_are_bit_for_bit_those_of_the_reference(height, width):
    """Slice writes mark the same pixels as the boolean masks; one gather cuts the same crops as
    the loop, at the borders too (centres beyond the map, crops clamped into the padding)."""
    generator = torch.Generator().manual_seed(height)
    semantic = torch.rand(4, height, width, generator=generator)
    for padding_class in (0, 3):
        assert torch.equal(padded_semantic(semantic, padding_class),
                           reference_padded_semantic(semantic, padding_class))
    assert torch.equal(padded_semantic(semantic, None), pad_to_multiple(semantic))
    centres = torch.rand(9, 2, generator=generator) * torch.tensor([width + 80.0, height + 80.0]) - 40
    for size in (32, 64):
        crops, origin = agent_crops(semantic, centres, size, 2)
        expected_crops, expected_origin = reference_agent_crops(semantic, centres, size, 2)
        assert torch.equal(crops, expected_crops) and torch.equal(origin, expected_origin)
        assert crops.is_contiguous()
