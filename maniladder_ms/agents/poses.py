"""Arm configurations that tasks start their robots in (joint targets, radians)."""

# LEAP side grasps on an upright container (PourGrainsHandToCup, OpenJarHands): arm joints 1-7 of a ready pose per
# side of `ml_dual_panda_leap`, each hand 10 cm above its line-up point for PourGrainsHandToCup's containers, turned
# for its side grasp (pinocchio IK; of 200 random starts, the solution furthest from the joint limits: 1.08 rad left,
# 0.96 rad right). From the top-down rest pose that is a ~180 degree wrist turn, which pd_ee_delta_pose servoing
# landed on a wrong IK branch on ~30 % of seeds. The left one is for a side grasp with the thumb low (palm normal
# along -y), the right one for the thumb high (palm normal along +y)
READY_ARM_JOINTS = {"left": (0.487, 0.683, -0.076, -1.836, -1.191, 1.363, -1.379),
                    "right": (0.664, 0.602, -0.869, -2.112, 1.569, 1.393, -0.213)}
