"""What the channels of a scene's semantic map mean: the segmentation classes, without torch, so
that code reading masks and tables (the pipeline's labels and benchmarks) need not import it.
`ynet.segmentation` holds the network that predicts them."""

# Channel index == value in the hand-labelled masks (`SDD_semantic_maps/*_mask.png`, values 1-5);
# channel 0 is the extra "padding" class for pixels outside the image (padding, warp borders).
# The masks carry no legend and the paper lists the classes in another order (pavement, terrain,
# structure, tree, road), so the mapping was determined by overlaying each value in its own colour
# on `reference.jpg` (deathCircle_0, little_0, bookstore_0, gates_1) and looking:
#   1 sidewalks, brick strips, plazas                      -> pavement
#   2 asphalt roads, roundabout lanes, bike paths          -> road
#   3 roofs, buildings, roundabout islands, fountain bases -> structure
#   4 lawns, bare soil                                      -> terrain
#   5 tree canopies, palms, bushes                          -> tree
CLASS_NAMES = ("padding", "pavement", "road", "structure", "terrain", "tree")
PAD_CLASS = 0
N_SCENE_CLASSES = 5  # N_c of the paper; the net outputs N_c + 1 channels
N_OUTPUTS = N_SCENE_CLASSES + 1
