"""Data: raw-file checksums and fetching, SDD annotations and splits, the window-table schema,
windowing and release chains, the ETH/UCY / TrajNet short-term windows and homographies, inD, the
hand-labelled masks, semantic maps, segmentation augmentation and Y-net's input tensors."""
