"""Y-net as a model library: tensors in, tensors out. No file paths, no DVC, no globals."""
