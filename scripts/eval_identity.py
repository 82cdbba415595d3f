"""Identity that survives the room (issue 20 item 2): id switches and the fraction of frames with
the right user id, with and without re-identification.

  .venv/bin/python scripts/eval_identity.py [--section sim|demo|all] [--seconds 60] [--seeds 2]
                                            [--people 2 3 4] [--demo-results R.jsonl] [--json OUT]

sim   The simulator (four ``kinect_color`` cameras, its 2D faults) with 2, 3 and 4 people: the
      navigator and bystanders who walk between random spots (and so cross and swap places).
      Every person also leaves the room once: their detections vanish from every camera for
      4-8 s (longer than ``tracks3d.max_missing_s``) and come back where they have walked to
      meanwhile. The chain is the live one's stages: OC-SORT per view, the Reconstructor
      (association, triangulation, 3D tracks, re-identification). Each reconstructed person is
      matched one-to-one to the simulated people (Hungarian on the hips' floor distance, within
      0.4 m; a person split in two by the association leaves one part unmatched). A person's right
      id is the first user id they got; a frame has the right id when the person is reported
      with it; an id switch is a change of a person's user id from one matched frame to the next
      (MOT's IDSW). Close encounters (two people within 0.6 m) are counted too.
demo  Pose2Sim's Demo_SinglePerson (real video, 4 views: the person and a bystander), from the
      per-frame results of ``cavewalk process`` (its 2D tracks), re-run through the Reconstructor
      with and without re-identification. There is no identity annotation; the right id is taken
      as in sim, with each person known by where they are (the two stand metres apart): the
      frames' 3D people are split by their floor position into the two people (2-means).

Both with ``identity.enabled`` false (before: ids from the 3D track only) and true (after).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.calibration.io import load_calibration  # noqa: E402
from pipeline.cave import box_cave  # noqa: E402
from pipeline.demo_data import demo_root  # noqa: E402
from pipeline.identity.config import IdentityConfig  # noqa: E402
from pipeline.pose.types import ViewDetections  # noqa: E402
from pipeline.sim.world import SimConfig, SimWorld  # noqa: E402
from pipeline.tracking.ocsort import MultiViewTracker  # noqa: E402
from pipeline.tracking.types import TrackedView  # noqa: E402
from pipeline.triangulation.config import ReconstructionConfig  # noqa: E402
from pipeline.triangulation.reconstructor import Reconstructor  # noqa: E402

MATCH_M = 0.4
CLOSE_M = 0.6


def drop_people(view: ViewDetections, ids: np.ndarray, gone: set[int]) -> ViewDetections:
    keep = np.array([int(i) not in gone for i in ids], dtype=bool)
    if keep.all():
        return view
    return dataclasses.replace(
        view,
        boxes_xyxy=view.boxes_xyxy[keep],
        box_scores=view.box_scores[keep],
        keypoints_xy=view.keypoints_xy[keep],
        keypoint_scores=view.keypoint_scores[keep],
    )


class IdScore:
    """Id switches and right-id frames of matched (person, user id) pairs, frame by frame."""

    def __init__(self) -> None:
        self.first: dict[int, int] = {}
        self.last: dict[int, int] = {}
        self.frames = self.right = self.switches = 0
        self.ids: set[int] = set()

    def add(self, person: int, user_id: int) -> None:
        self.frames += 1
        self.ids.add(user_id)
        self.first.setdefault(person, user_id)
        self.right += self.first[person] == user_id
        if person in self.last and self.last[person] != user_id:
            self.switches += 1
        self.last[person] = user_id

    def summary(self) -> dict[str, Any]:
        return {
            "person_frames": self.frames,
            "id_switches": self.switches,
            "right_id_fraction": round(self.right / self.frames, 4) if self.frames else None,
            "user_ids_used": len(self.ids),
        }


def run_sim(
    people: int, seed: int, seconds: float, identity: IdentityConfig, fps: float = 30.0
) -> dict[str, Any]:
    world = SimWorld.build(box_cave(), SimConfig(fps=fps, bystanders=people - 1, seed=seed))
    rng = np.random.default_rng(1000 + seed)
    n = int(seconds * fps)
    exits = []  # (person, start frame, end frame): each person leaves once
    for i in range(people):
        start = rng.uniform(0.15, 0.75) * seconds
        exits.append((i, int(start * fps), int((start + rng.uniform(4.0, 8.0)) * fps)))
    tracker = MultiViewTracker([c.name for c in world.cameras])
    rec = Reconstructor(world.cameras, ReconstructionConfig(identity=identity))
    score = IdScore()
    close = duplicates = 0
    for k in range(n):
        f = world.step()
        gone = {i for i, a, b in exits if a <= k < b}
        views = [drop_people(v, ids, gone) for v, ids in zip(f.views, f.view_people, strict=True)]
        hips = np.array([j[[11, 12]].mean(axis=0)[:2] for _, j in f.truth])
        present = [i for i in range(people) if i not in gone]
        close += sum(np.linalg.norm(hips[a] - hips[b]) < CLOSE_M for a in present for b in present if a < b)
        people3d = rec.update(tracker.update(views), f.timestamp_s)
        if not people3d:
            continue
        cost = np.linalg.norm(np.array([p.position_m[:2] for p in people3d])[:, None] - hips[None], axis=2)
        cost[:, list(gone)] = 1e6
        for r, c in zip(*linear_sum_assignment(cost), strict=True):  # one 3D person per person
            if cost[r, c] <= MATCH_M:
                score.add(int(c), people3d[r].user_id)
        duplicates += len(people3d) - min(len(people3d), len(present))
    return score.summary() | {"close_frames": int(close), "exits": len(exits), "extra_people3d": duplicates}


def demo_frames(path: Path) -> list[tuple[float, list[Any]]]:
    """(timestamp, tracked views) of every line of a ``cavewalk process`` results file."""
    out = []
    for line in path.read_text().splitlines():
        rec = json.loads(line)
        views = []
        for v in rec["views"]:
            ppl = v["people"]
            kp = np.array(
                [[[np.nan if c is None else c for c in k[:2]] for k in p["keypoints"]] for p in ppl],
                dtype=np.float32,
            ).reshape(len(ppl), 17, 2)
            sc = np.array(
                [[0.0 if k[2] is None else k[2] for k in p["keypoints"]] for p in ppl], dtype=np.float32
            ).reshape(len(ppl), 17)
            boxes = np.array([p["bbox"] for p in ppl], dtype=np.float32).reshape(len(ppl), 4)
            det = ViewDetections(
                v["camera"], rec["frame"], rec["t"], (1, 1), boxes, np.ones(len(ppl), np.float32), kp, sc
            )
            views.append(
                TrackedView(det, np.array([p["track_id"] for p in ppl], dtype=np.int64), np.arange(len(ppl)))
            )
        out.append((float(rec["t"]), views))
    return out


def run_demo(results: Path, calibration: Path, identity: IdentityConfig) -> dict[str, Any]:
    cams = load_calibration(calibration)
    rec = Reconstructor(cams, ReconstructionConfig(identity=identity))
    frames = demo_frames(results)
    seen: list[tuple[int, int, np.ndarray]] = []
    for k, (t, views) in enumerate(frames):
        for p in rec.update(views, t):
            seen.append((k, p.user_id, p.position_m[:2]))
    if not seen:
        return {"person_frames": 0}
    xy = np.array([s[2] for s in seen])
    centres = np.array([xy[np.argmin(xy[:, 0])], xy[np.argmax(xy[:, 0])]])  # 2-means from the extremes
    for _ in range(20):
        lab = np.argmin(np.linalg.norm(xy[:, None] - centres[None], axis=2), axis=1)
        centres = np.array([xy[lab == c].mean(axis=0) if np.any(lab == c) else centres[c] for c in (0, 1)])
    score = IdScore()
    for (_k, uid, _), person in zip(seen, lab, strict=True):
        score.add(int(person), uid)
    return score.summary() | {"frames": len(frames), "people_centres_m": np.round(centres, 2).tolist()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--section", choices=("sim", "demo", "all"), default="all")
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--people", type=int, nargs="*", default=[2, 3, 4])
    ap.add_argument("--demo-results", type=Path, help="a `cavewalk process` JSONL of the demo videos")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    report: dict[str, Any] = {
        "machine": {
            "cpu": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "load_avg": [round(v, 2) for v in os.getloadavg()],
        }
    }
    modes = {"before": IdentityConfig(enabled=False), "after": IdentityConfig()}
    if args.section in ("sim", "all"):
        sim: dict[str, Any] = {}
        for n_people in args.people:
            for name, cfg in modes.items():
                runs = [run_sim(n_people, seed, args.seconds, cfg) for seed in range(args.seeds)]
                frames = sum(r["person_frames"] for r in runs)
                right = sum(r["right_id_fraction"] * r["person_frames"] for r in runs)
                row = {
                    "id_switches": sum(r["id_switches"] for r in runs),
                    "person_frames": frames,
                    "right_id_fraction": round(right / frames, 4),
                    "user_ids_used": [r["user_ids_used"] for r in runs],
                    "close_frames": sum(r["close_frames"] for r in runs),
                    "exits": sum(r["exits"] for r in runs),
                    "extra_people3d": sum(r["extra_people3d"] for r in runs),
                }
                sim[f"{n_people}p/{name}"] = row
                print(
                    f"sim {n_people} people {name:6s}: id switches {row['id_switches']:3d}, right id "
                    f"{100 * row['right_id_fraction']:5.1f} % of {frames} person-frames, user ids "
                    f"{row['user_ids_used']}, exits {row['exits']}, close frames {row['close_frames']}",
                    flush=True,
                )
        report["sim"] = sim | {"seconds": args.seconds, "seeds": args.seeds}
    if args.section in ("demo", "all"):
        if args.demo_results is None:
            raise SystemExit("--demo-results R.jsonl (from `cavewalk process` on the demo videos) is needed")
        calib = demo_root(Path.home() / ".cache" / "cavewalk") / "calibration" / "Calib.qca.txt"
        demo = {name: run_demo(args.demo_results, calib, cfg) for name, cfg in modes.items()}
        for name, row in demo.items():
            print(f"demo {name:6s}: {row}", flush=True)
        report["demo"] = demo
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
