"""Hand tools built from boxes: an L-shaped hook for pulling objects from out of reach (HookCubeWithTool)."""

from __future__ import annotations

from dataclasses import dataclass

import sapien
import sapien.physx as physx
import sapien.render

from mani_skill.envs.scene import ManiSkillScene


@dataclass(frozen=True)
class HookShape:
    """A handle `handle_length` long along the tool's local x, and at its +x end a hook `hook_length` long
    sticking out along +y; both `width` wide and `height` high. The origin is the handle's centre."""

    handle_length: float
    hook_length: float
    width: float = 0.025
    height: float = 0.03

    def parts(self) -> list[tuple[list[float], list[float]]]:
        """(centre, half size) of the handle, then the hook, in the tool frame."""
        w, h = self.width / 2, self.height / 2
        hook_x = self.handle_length / 2 - w
        return [([0.0, 0.0, 0.0], [self.handle_length / 2, w, h]),
                ([hook_x, w + self.hook_length / 2, 0.0], [w, self.hook_length / 2, h])]

    @property
    def pull_face_x(self) -> float:
        """Local x of the hook's inner face (towards the handle's far end), which pulls an object."""
        return self.handle_length / 2 - self.width

    @property
    def hook_span(self) -> tuple[float, float]:
        """Local y range the hook's pulling face covers."""
        return self.width / 2, self.width / 2 + self.hook_length


def build_hook(scene: ManiSkillScene, name: str, shape: HookShape, density: float, color,
               friction: float = 0.3) -> "Actor":
    """The hook as a dynamic actor lying flat (origin `shape.height` / 2 above the table); `friction`: its
    surface's (PhysX averages it with the other body's)."""
    builder = scene.create_actor_builder()
    material = sapien.render.RenderMaterial(base_color=list(color), roughness=0.5)
    surface = physx.PhysxMaterial(friction, friction, 0.0)
    for centre, half in shape.parts():
        builder.add_box_collision(sapien.Pose(p=centre), half_size=half, material=surface, density=density)
        builder.add_box_visual(sapien.Pose(p=centre), half_size=half, material=material)
    builder.initial_pose = sapien.Pose(p=[0, 0, shape.height / 2])
    return builder.build(name=name)
