"""OC-SORT on the simulator's multi-user keypoints (navigator + two bystanders walking around,
occluding one another, with detector noise, misses and ghost detections)."""

from __future__ import annotations

from collections import Counter, defaultdict

import pytest

from pipeline.cave import box_cave
from pipeline.sim.world import SimConfig, SimWorld
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 3])
def test_no_track_ever_takes_over_another_person(seed: int) -> None:
    world = SimWorld.build(box_cave(3.0, 3.0, 2.5, (1920, 1600)), SimConfig(fps=30, bystanders=2, seed=seed))
    tracker = MultiViewTracker([c.name for c in world.cameras], OCSortConfig())
    people_of_track: dict[tuple[str, int], Counter[int]] = defaultdict(Counter)
    tracks_of_person: dict[tuple[str, int], Counter[int]] = defaultdict(Counter)
    for frame in world.run(300):
        for view, truth in zip(tracker.update(list(frame.views)), frame.view_people, strict=True):
            for tid, row in zip(view.track_ids.tolist(), view.detection_index.tolist(), strict=True):
                person = int(truth[row])
                if person >= 0:  # -1: a ghost detection of the simulated detector
                    people_of_track[(view.camera, tid)][person] += 1
                    tracks_of_person[(view.camera, person)][tid] += 1
    swapped = {k: dict(c) for k, c in people_of_track.items() if len(c) > 1}
    assert not swapped, f"track ids that followed two people: {swapped}"
    assert len(tracks_of_person) >= 8, "most people are seen by most cameras"
    for key, ids in tracks_of_person.items():
        total = sum(ids.values())
        if total >= 60:
            _, frames = ids.most_common(1)[0]
            assert frames >= 0.8 * total, f"{key}: ids {dict(ids)}; one id should hold most frames"
