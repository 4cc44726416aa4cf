"""Named LEAP hand postures: the one table of 16-joint targets the solvers close and open hands to."""

from __future__ import annotations

import numpy as np

# LEAP grasp synergies: 16 joint targets (LEAP order j0..j15: index, middle, ring, thumb x 4).
# MCP side joints (j0, j4, j8) stay 0. "power" closes on an object centred at the hand's tcp (the
# tcp was placed there, see scripts/make_agents.py); the targets lie past the contact so the PD drives
# squeeze. Found by a grid search over finger and thumb postures lifting a 5 cm cube and holding a
# 300 g can; shallower postures drop the can, deeper ones push the cube out while closing.
LEAP_SYNERGIES = {
    "open": np.zeros(16),
    # fingers slightly bent, thumb swung under the palm: the approach posture of "power" (take it once
    # above the object), so that closing only curls digits towards the object instead of sweeping the
    # thumb across it
    "preshape": np.array([0.0, 0.4, 0.0, 0.0] * 3 + [1.5, 0.0, 0.0, 0.0]),
    # fingers curl over the far side of the object, the thumb swings under the palm and presses the near side
    "power": np.array([0.0, 1.5, 0.6, 0.4, 0.0, 1.5, 0.6, 0.4, 0.0, 1.5, 0.6, 0.4, 1.6, 0.6, 0.8, 0.8]),
    # index + thumb tips meet, middle/ring tucked away
    "pinch": np.array([0.0, 1.1, 0.6, 0.4, 0.0, 0.2, 0.2, 0.2, 0.0, 0.2, 0.2, 0.2, 1.6, 0.4, 0.5, 0.5]),
    # index and middle fingers straight down (bent 90 degrees at their knuckles), spread sideways 0.25 rad
    # each, ring curled, thumb flat: the approach posture of "scissor"
    "scissor_open": np.array([-0.25, 1.57, 0.0, 0.0, 0.25, 1.57, 0.0, 0.0, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    # the two fingers swung together at their side joints: a thin object (a 1.6 cm rope) lying on the table
    # between the two fingertips is held between their side faces like a cigarette, the only pinch whose
    # contacts reach down to 8 mm above the table. The side targets (0.02 rad, just past straight) stop the
    # fingers ~0.05 rad short on a 1.6 cm rope: ~1.4 N m, under the 1.9 N m force limit, so the pair keeps
    # its stiffness. Targets far past each other (0.12 rad) saturate both drives: the pinched pair then
    # drifts sideways as one, the rope's beads ratchet through it and 2 of 5 seeds dropped the rope after
    # 20-40 hold steps; at 0.02 (and 0.0) 10/10 held 80 steps
    "scissor": np.array([0.02, 1.57, 0.0, 0.0, -0.02, 1.57, 0.0, 0.0, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    # "scissor_open" and "scissor" with the ring finger bent down at its knuckle too and curled back under the palm:
    # the flat ring of "scissor" sticks out ~5 cm past the knuckles, where two hands pinching one pen a few
    # centimetres apart, fingers towards each other, meet ring on ring (HandoverPenHands)
    "scissor_open_ring_tucked": np.array([-0.25, 1.57, 0.0, 0.0, 0.25, 1.57, 0.0, 0.0, 0.0, 1.57, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    "scissor_ring_tucked": np.array([0.02, 1.57, 0.0, 0.0, -0.02, 1.57, 0.0, 0.0, 0.0, 1.57, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    # index bent 90 degrees at its knuckle, straight (points down from a top-down hand), middle/ring curled
    # at PIP/DIP, thumb flat: the index tip is the lowest point by 9 cm, for pressing buttons
    "point": np.array([0.0, 1.57, 0.0, 0.0, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    # a cupped palm for loose grains on a palm-up hand: the three fingers raised 0.6 rad at the knuckles and bent
    # 0.3 at PIP/DIP, index and ring turned 0.1 rad at their side joints towards the middle finger (narrowing the
    # gaps), thumb swung 1.0 under the palm as the dish's fourth side. 40 beans (4 mm) dropped on a palm-up right
    # hand: 36 still on it after 40 steps and a 20 cm carry at 5 mm a step (HandoverBallHands' CRADLE_DISH 27, the
    # knuckles at 0.9 34; measured for CupBeansHands)
    "cup": np.array([0.1, 0.6, 0.3, 0.3, 0.0, 0.6, 0.3, 0.3, -0.1, 0.6, 0.3, 0.3, 1.0, 0.0, 0.3, 0.3]),
    # a LEAP giver's grip for a hand-to-hand pass (HandoverBallHands, HandoverMugHands): fingers further round at the
    # knuckle (j1 2.1), less at PIP/DIP, than "power". Holding a tennis ball 100 steps at the meeting point after the
    # carry (seeds 100-109): power 5/10, [0,1.8,0.6,0.4] 7/10, this 10/10; it also keeps the ball through the roll to
    # palm-up (4/4) where power drops it at 30-60 degrees of tilt
    "giver": np.array([0, 2.1, 0.3, 0.2] * 3 + [1.6, 0.6, 0.8, 0.8]),
    # the further curl for a ball left on the palm with no finger on it: holds it with the ring tip (12 N) against the
    # palm (13 N), where [0, 1.5, 1.4, 1.2] flings it off (picked on seeds 100-149: docs/tasks/HandoverBallHands.md)
    "cradle_squeeze": np.array([0, 1.9, 1.0, 0.8] * 3 + [1.6, 0.6, 0.8, 0.8]),
    # "point" with the index swung back past straight down (MCP 2.0 rad): its tip ends 4.1 cm behind the tcp
    # instead of 1.7 cm ahead (SlideCardToEdgeHand presses a card's centre with it, the tcp 7.8 cm further from the
    # robot's base, so the top-down hand gets low enough over cards nearest the robot; chosen on seeds 100-149:
    # docs/tasks/SlideCardToEdgeHand.md)
    "point_back": np.array([0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 1.6, 1.6, 0.0, 0.0, 0.0, 0.0]),
    # fingers bent 0.5 rad at their knuckles only, thumb flat: palms pressed onto a box's sides (CarryBoxToShelfHands)
    "knuckle_curl": np.array([0.0, 0.5, 0.0, 0.0] * 3 + [0.0, 0.0, 0.0, 0.0]),
    # The rim grasp: index and middle fingers bent down at their knuckles, the thumb swung down from the palm's wrist
    # end opposite them, all three tips at one height, the lid between them (a top-down pinch on its rim, the palm
    # ~9 cm above it); it closes by bending the finger knuckles and the thumb's tip joint towards each other. The
    # thumb opens only to joint 14 at -0.1 (its pad ~0.5 cm off the rim): opened further it rested on the holding
    # hand's ring-finger knuckle, which stands 6-7 cm from the lid's axis up to near the lid top. On a clamped jar
    # its close turns the lid 0.02-0.06 rad and it holds the lid through a stroke at ~0.04 rad/step; it turns the lid
    # ~1:1 with the wrist, and the opening hand, the flat one's swinging thumb no longer dragging the lid, opens to
    # "rim_open" (OpenJarHands, seeds 100-109: 8/10, the flat hand 6/10)
    "rim_open": np.array([0.0, 1.45, 0.0, 0.0, 0.0, 1.45, 0.0, 0.0, 0.0, 0.2, 0.2, 0.2, 1.67, 0.0, -0.1, 0.0]),
    "rim_close": np.array([0.0, 1.75, 0.0, 0.0, 0.0, 1.75, 0.0, 0.0, 0.0, 0.2, 0.2, 0.2, 1.67, 0.0, 0.3, 0.0]),
    # a palm pouring beans into a cup (CupBeansHands): during the tilt the middle finger opens flat, the index and ring half ("cup"'s knuckles 0.6 / PIP-DIP 0.3 halved),
    # low walls funnelling the beans onto the middle finger (the 7 cm mouth is narrower than the 12.6 cm hand); kept in
    # "cup" the curl hooks the beans in at any tilt (tilted to 70 deg, 9 of 21 still on it). Of 15 beans in the palm
    # this delivers 11-13 (seeds 100-104); index and ring curled to 0.9 / 0.5 6-8, flat 8-11
    "pour_flat": np.array([0.1, 0.3, 0.15, 0.15, 0.0, 0.0, 0.0, 0.0, -0.1, 0.3, 0.15, 0.15, 1.0, 0.0, 0.3, 0.3]),
    # the thumb raised (j12 near its lower limit, -0.349) in the next three: open, its links reach 4 mm below the
    # palm's underside, over a card's stand, and would hold the palm off the card; the ring finger stays straight
    # index and middle hooked at PIP / DIP (SlideCardToEdgeHand: in front of the card's end)
    "hook_curl": np.array([0.0, 0.0, 1.57, 1.57, 0.0, 0.0, 1.57, 1.57, 0.0, 0.0, 0.0, 0.0, -0.34, 0.0, 0.0, 0.0]),
    # then swung down and back at their MCP joints, pressing an overhanging card against the palm
    "clamp": np.array([0.0, 1.57, 1.57, 1.57, 0.0, 1.57, 1.57, 1.57, 0.0, 0.0, 0.0, 0.0, -0.34, 0.0, 0.0, 0.0]),
    # open, the thumb raised
    "open_thumb_up": np.array([0.0] * 12 + [-0.34, 0.0, 0.0, 0.0]),
    # "power"'s fingers with the thumb joints beyond its base only slightly bent: a hand's side grasp of a standing
    # cup or glass ("power"'s 0.6 / 0.8 / 0.8 pushed a standing glass over by ~30 deg while closing; solvers.side_grasps)
    "side_power": np.array([0.0, 1.5, 0.6, 0.4] * 3 + [1.6, 0.3, 0.3, 0.3]),
    # "side_power" with the ring finger open (curled, it reached the jar's lid: OpenJarHands' holding hand)
    "side_power_ring_open": np.array([0.0, 1.5, 0.6, 0.4] * 2 + [0.0] * 4 + [1.6, 0.3, 0.3, 0.3]),
    # fingers curled at PIP / DIP round a cup held from the side, the thumb tip pressing (PourWaterHand: the cup turns
    # 12-20 deg in the hand and stays, none lost on seeds 100-109)
    "side_wrap": np.array([0.0, 1.5, 1.0, 1.0] * 3 + [1.6, 0.6, 0.6, 0.6]),
    # "power"'s fingers, the thumb swung 1.0 under the palm and straight beyond it (PourGrainsHandToCup's holder: its
    # thumb at 8-38 N, three fingertips at 6-14 N on the cup)
    "side_power_thumb_straight": np.array([0.0, 1.5, 0.6, 0.4] * 3 + [1.0, 0.0, 0.0, 0.0]),
    # a palm-up hand tipping a 5 cm cube lying on its finger bases over towards the heel (ReorientCubeInHand): the
    # three fingers raised at their knuckles only, straight, thumb flat (at 1.2 rad the cube has tipped the quarter
    # turn onto the palm, seed 0: its top 1.6 deg from up); then curled over the tipped cube, knuckles, PIP and DIP at
    # 1.6, pressing it onto the palm (a finger against the palm: `ee.holds`)
    "roll_tip": np.array([0.0, 1.2, 0.0, 0.0] * 3 + [0.0, 0.0, 0.0, 0.0]),
    "roll_grip": np.array([0.0, 1.6, 1.6, 1.6] * 3 + [0.0, 0.0, 0.0, 0.0]),
}
