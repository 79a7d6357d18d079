"""symgrasp: learning 6-DoF grasp detection for parallel grippers.

The planar-symmetric SO(3) representation of Ko, Ikeda, Sato & Nishiwaki (CoRL 2024)
expresses the two 180°-flipped poses of a parallel gripper with one parameter set:
the approach axis e_x as a 3-vector and the closing axis e_z as a 2D Bingham distribution.
"""

from symgrasp.gl_backend import choose_gl_backend

# MuJoCo reads MUJOCO_GL once, when it is first imported, and any subpackage may import it
# first (``symgrasp.sim.world`` does): choose the backend before any of them loads.
choose_gl_backend()

__version__ = "0.1.0"
