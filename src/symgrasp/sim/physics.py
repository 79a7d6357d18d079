"""Every MuJoCo contact and solver setting of the world, in one place.

Why these values:

- ``cone="elliptic"`` with ``impratio="10"``: the default pyramidal cone with impratio 1
  lets a squeezed object creep out of the fingers (friction is soft relative to the normal
  force): a held 0.6 kg box slid 1.5–2.5 mm in 3 s, against 0.13–0.18 mm with these.
- 50 Newton iterations: with 30, piles of light objects at impratio 10 did not converge and
  some objects flew off.
- ``condim 4`` on fingers and objects: torsional friction, so an object pinched off its
  centre of mass does not spin about the closing axis like a pendulum.
- ``condim 6`` on the table: rolling friction, so cylinders, capsules and spheres come to
  rest in a pile instead of rolling forever. MuJoCo takes the larger ``condim`` of a pair,
  so only contacts with the table pay for it.
- Friction coefficients of a pair are the element-wise *maximum* of the two geoms, so the
  fingers and the table carry low sliding friction and the object's own (randomised)
  coefficient decides how well it is held and how it slides.
- ``implicitfast`` integration with a 2 ms step: stable with stiff finger damping and the
  mocap weld, and fast enough for a full grasp trial in a few tens of milliseconds.
"""

from __future__ import annotations

TIMESTEP = 0.002
"""Simulation step [s]."""

FINGER_FRICTION = (0.1, 0.005, 0.0)
"""Sliding, torsional, rolling friction of finger geoms (the object's sliding value wins)."""

TABLE_FRICTION = (0.1, 0.005, 0.003)
"""Sliding, torsional, rolling friction of the table."""

OBJECT_TORSION_ROLL = (0.005, 0.0001)
"""Torsional and rolling friction of objects; sliding friction is randomised per object."""

HAND_GROUP = 2
"""Geom group of the hand: excluded from depth images."""

HIDDEN_GROUP = 3
"""Geom group of things no camera sees: the table's collision plane, the pile walls."""

STIFF_SOLREF = "0.004 1"
STIFF_SOLIMP = "0.95 0.99 0.001"
"""Stiff, nearly hard contacts, joint limits and equalities (time constant 2 steps, 99 %
impedance): a 70 N squeeze then penetrates well under a millimetre instead of centimetres,
which keeps grasped objects from being spat out when the fingers relax."""

OBJECT_SOLREF = "0.02 1"
"""Objects keep MuJoCo's default softness among themselves and on the table (with the stiff
values piles settled less calmly); finger geoms carry ``solmix=1000`` so that a
finger–object contact takes the fingers' stiff parameters."""

MESH_OBJECT_SOLREF = "0.01 1"
MESH_OBJECT_SOLIMP = "0.95 0.99 0.001"
"""Mesh objects (convex parts of real meshes) are stiffer: their masses span three orders of
magnitude (5 g to 7 kg in VGN's sets), and MuJoCo's soft contact penetrates in proportion to
the load over the contact's effective mass, so a 0.5 kg shampoo bottle sank up to 38 mm into
a 30 g pair of pliers with the default softness. Over 150 settled VGN piles (seeds 0–149),
objects interpenetrating deeper than 2 mm fell from 39 of 740 to 3 of 731 (deepest 4.8 mm),
objects still moving from 7 to 2, and settling got faster (experiments/scene_physics.py holds
the 1 000-scene counts). Procedural objects keep ``OBJECT_SOLREF``, so every result
published on them stands."""

WELD_SOLREF = STIFF_SOLREF
"""Stiff mocap weld: the hand follows its commanded pose within a millimetre under load."""


def option_xml() -> str:
    """The ``<option>``, ``<visual>`` and ``<default>`` blocks shared by every world."""
    friction = " ".join(str(f) for f in FINGER_FRICTION)
    table = " ".join(str(f) for f in TABLE_FRICTION)
    return f"""
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP}" integrator="implicitfast" cone="elliptic" impratio="10"
          solver="Newton" iterations="50" ls_iterations="20"/>
  <statistic extent="1" center="0.15 0.15 0.15"/>
  <visual>
    <global offwidth="1280" offheight="960"/>
    <map znear="0.01" zfar="5"/>  <!-- × extent 1: depth from 1 cm to 5 m -->
    <quality shadowsize="1024"/>
  </visual>
  <default>
    <joint solreflimit="{STIFF_SOLREF}" solimplimit="{STIFF_SOLIMP}"/>
    <equality solref="{STIFF_SOLREF}" solimp="{STIFF_SOLIMP}"/>
    <default class="object">
      <geom condim="4" solref="{OBJECT_SOLREF}"/>
      <default class="mesh_object">
        <geom solref="{MESH_OBJECT_SOLREF}" solimp="{MESH_OBJECT_SOLIMP}"/>
      </default>
    </default>
    <default class="finger">
      <geom condim="4" friction="{friction}" group="{HAND_GROUP}" solref="{STIFF_SOLREF}"
            solmix="1000"
            solimp="{STIFF_SOLIMP}" rgba="0.15 0.15 0.15 1"/>
    </default>
    <default class="hand">
      <geom group="{HAND_GROUP}" condim="3" friction="{friction}" rgba="0.85 0.85 0.88 1"/>
    </default>
    <default class="table">
      <geom condim="6" friction="{table}" rgba="0.72 0.6 0.45 1"/>
    </default>
  </default>
"""
