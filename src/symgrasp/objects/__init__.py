"""Object sets on disk: the data folder, VGN's household meshes and a user's own meshes.

The procedural sets live in `symgrasp.sim.objects` and need no files; the sets here are read
from the data folder (`folder.data_folder`) or from a path the user gives.
"""
