"""symgrasp: learning 6-DoF grasp detection for parallel grippers.

The planar-symmetric SO(3) representation of Ko, Ikeda, Sato & Nishiwaki (CoRL 2024)
expresses the two 180°-flipped poses of a parallel gripper with one parameter set:
the approach axis e_x as a 3-vector and the closing axis e_z as a 2D Bingham distribution.
"""

__version__ = "0.1.0"
