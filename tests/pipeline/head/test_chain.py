"""The head stage inside the live chain's fusion: the simulated navigator's head, frame by frame,
against the simulator's ground truth."""

from __future__ import annotations

import numpy as np

from pipeline.cave import box_cave
from pipeline.head.config import HeadConfig
from pipeline.head.pose import angle_deg, head_pose_from_joints
from pipeline.runtime.chain import ChainConfig, build_chain
from pipeline.runtime.messages import DetectedFrame
from pipeline.sim.world import SimConfig, SimWorld


def run(head: HeadConfig, frames: int = 150) -> tuple[list[float], list[float], int]:
    world = SimWorld.build(box_cave(), SimConfig(fps=30.0, bystanders=1, seed=11))
    chain = build_chain(ChainConfig(
        cameras=tuple(world.cameras),
        camera_names=tuple(c.name for c in world.cameras),
        recognition=None,
        head=head,
    ))
    pos_mm, rot_deg, with_head = [], [], 0
    for _ in range(frames):
        f = world.step()
        result = chain.update(
            DetectedFrame(f.frame_index, f.timestamp_s, f.views, f.timestamp_s, f.timestamp_s)
        )
        assert len(result.heads) <= 1 and all(h.user_id == result.navigator for h in result.heads), (
            "one head per navigator, the navigator's"
        )
        if not result.heads:
            continue
        with_head += 1
        truth = head_pose_from_joints(f.truth[0][1], scale=None)
        pose = result.heads[0].predict(0.0)
        pos_mm.append(1000 * float(np.linalg.norm(np.asarray(pose.position_m) - truth.position_m)))
        r = np.stack([np.cross(pose.forward, pose.up), pose.forward, pose.up], axis=1)
        rot_deg.append(angle_deg(r, truth.rotation))
    return pos_mm, rot_deg, with_head


def test_fusion_streams_the_navigators_head_close_to_the_truth() -> None:
    pos_mm, rot_deg, with_head = run(HeadConfig())
    assert with_head >= 100, f"a head in most frames once the navigator is chosen, got {with_head}/150"
    assert np.median(pos_mm) < 15.0, f"median position error {np.median(pos_mm):.1f} mm"
    assert np.median(rot_deg) < 6.0, f"median rotation error {np.median(rot_deg):.1f} deg"
    assert np.percentile(rot_deg, 95) < 30.0


def test_head_turned_off_gives_no_heads() -> None:
    assert run(HeadConfig(enabled=False), frames=40)[2] == 0
