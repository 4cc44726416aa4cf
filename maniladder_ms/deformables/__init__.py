"""Deformable objects without a soft-body solver, as rigid-body PhysX proxies built through ManiSkill.

- `rope`: capsule-chain articulation (free or one end fixed); straightness, winding, knot metrics.
- `cloth`: sheets of particles linked by spring drives (towel, shirt, bag, tent panel), drawn as
  tiles; fold, flatness and hanging metrics.
- `clay`: a lattice of spheres linked by springs that yield (plasticity); height, width, dent metrics.
- `metrics`: footprint area, region coverage and IoU on 2D/voxel grids (cloth and clay).
- `particles`: liquid (low friction) and granular (high friction) spheres; container fill metrics.
  The containers themselves are in `maniladder_ms.objects.containers`.

Each builder returns an object that wraps ManiSkill actors/articulations, so get_state/set_state,
batching over num_envs and every obs mode keep working. `showcase` registers one demo env per kind.
"""
