"""Training data: per-object grasp databases, cluttered scenes with voxel labels, datasets."""
