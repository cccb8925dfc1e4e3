"""The PR2's links, dimensions and colours that both its collision model
(:mod:`planner.robots.pr2.model`, which re-exports them) and its drawn meshes
(:mod:`planner.robots.pr2.visuals`) are built from; the two modules import this one, not each
other.
"""

from __future__ import annotations

from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent  # holds the URDF and its meshes (in the wheel too)

Vec3 = tuple[float, float, float]

ROOT_LINK = "base_footprint"  # the body's base; its pose is the robot's planar pose
BASE_LINK = "base_link"
TORSO_LINK = "torso_lift_link"

# ---------------------------------------------------------------------------------------------
# Dimensions (metres), from the public pr2_description kinematics; the arm chain is exactly the
# one compiled into pr2_ikfast, whose frame is base_link (BASE_LINK_HEIGHT above base_footprint).
# ---------------------------------------------------------------------------------------------

BASE_LINK_HEIGHT = 0.051  # base_footprint -> base_link
TORSO_ORIGIN: Vec3 = (-0.05, 0.0, 0.739675)  # base_link -> torso_lift_link at zero lift
SHOULDER_Y = 0.188  # torso_lift_link -> {l,r}_shoulder_pan_link (+y left, -y right)
SHOULDER_LIFT_X = 0.1  # shoulder pan axis -> shoulder lift axis
UPPER_ARM_LENGTH = 0.4  # upper arm roll -> elbow flex
FOREARM_LENGTH = 0.321  # forearm roll -> wrist flex
TOOL_LENGTH = 0.18  # wrist roll / palm -> tool frame between the fingertips
HEAD_PAN_ORIGIN: Vec3 = (-0.01707, 0.0, 0.38145)  # torso_lift_link -> head_pan_link
HEAD_TILT_ORIGIN: Vec3 = (0.068, 0.0, 0.0)  # head_pan_link -> head_tilt_link
BASE_SIZE: Vec3 = (0.668, 0.668, 0.30)  # the square base box
FINGER_ORIGIN_X = 0.13  # palm -> finger joints
FINGER_LENGTH = 0.08  # fingers reach 3 cm past the tool frame

# Colours, by the material names the URDF and the meshes use.
MATERIALS: dict[str, tuple[float, float, float, float]] = {
    "white": (0.92, 0.92, 0.9, 1.0),
    "light_grey": (0.72, 0.72, 0.72, 1.0),
    "grey": (0.5, 0.5, 0.52, 1.0),
    "dark_grey": (0.25, 0.25, 0.27, 1.0),
    "black": (0.07, 0.07, 0.07, 1.0),
}
