"""Cross-view association: which 2D person in each camera is the same physical person.

Two people seen by different cameras are compared by the symmetric epipolar distance of their
confident joints (pixels; each joint must lie on the epipolar line of its counterpart). People are
then grouped by greedy average-linkage clustering, at most one person per camera per group, with a
memory prior: people that were the same user in recent frames (their (camera, track_id) links)
are pulled together, people known to be different users are pushed apart.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.skeleton import FLIP_PAIRS, NUM_JOINTS
from pipeline.triangulation.config import AssociationParams
from pipeline.triangulation.dlt import CameraRig

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


FLIP_PERM = np.arange(NUM_JOINTS)
for _a, _b in FLIP_PAIRS:
    FLIP_PERM[_a], FLIP_PERM[_b] = _b, _a


def _skew(v: F64) -> F64:
    """(..., 3) vectors -> (..., 3, 3) cross-product matrices."""
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], axis=-1),
            np.stack([v[..., 2], z, -v[..., 0]], axis=-1),
            np.stack([-v[..., 1], v[..., 0], z], axis=-1),
        ],
        axis=-2,
    )


def essential_matrices(Rt: F64) -> F64:
    """(C, 3, 4) world-to-camera [R | t] -> (C, C, 3, 3) E[b, a] with x_b' E[b, a] x_a = 0.

    For normalised homogeneous coordinates: R_ba = R_b R_a', t_ba = t_b - R_ba t_a, E = [t_ba]x R_ba.
    """
    rot, t = Rt[:, :, :3], Rt[:, :, 3]
    r_ba = np.einsum("bij,akj->baik", rot, rot)
    t_ba = t[:, None, :] - np.einsum("baij,aj->bai", r_ba, t)
    e: F64 = _skew(t_ba) @ r_ba
    return e


def epipolar_distances(
    rig: CameraRig,
    camera_index: I64,
    xy: F64,
    weights: F64,
    min_common_joints: int,
) -> F64:
    """(M, M) mean symmetric epipolar distance between M people, pixels.

    camera_index: (M,) camera of each person; xy: (M, 17, 2) normalised coordinates;
    weights: (M, 17) > 0 where a joint is confidently seen. Pairs in the same camera, or with fewer
    than ``min_common_joints`` joints seen in both, are +inf.
    """
    m = camera_index.shape[0]
    if xy.shape != (m, NUM_JOINTS, 2) or weights.shape != (m, NUM_JOINTS):
        raise InputError(f"expected xy ({m}, 17, 2) and weights ({m}, 17), got {xy.shape}, {weights.shape}")
    if m == 0:
        return np.zeros((0, 0))
    e = essential_matrices(rig.Rt)
    xh = np.concatenate([np.nan_to_num(xy), np.ones((m, NUM_JOINTS, 1))], axis=2)  # (M, 17, 3)
    e_pair = e[camera_index[None, :], camera_index[:, None]]  # [i, j] = E[cam_j, cam_i]: line in j
    lines = np.einsum("ijab,ikb->ijka", e_pair, xh)  # (M, M, 17, 3): line in view of j of i's joints
    norm = np.sqrt(lines[..., 0] ** 2 + lines[..., 1] ** 2)
    focal_j = rig.focal_px[camera_index][None, :, None]
    out = np.full((m, m), np.inf)
    # Compare j's joints as they are and with left and right swapped (a view with a left/right swap
    # still belongs to its person; the reconstructor unswaps it), keep the better.
    for perm in (np.arange(NUM_JOINTS), FLIP_PERM):
        xh_j, w_j = xh[:, perm], weights[:, perm]
        num = np.abs(np.einsum("ijka,jka->ijk", lines, xh_j))
        with np.errstate(divide="ignore", invalid="ignore"):
            d_in_j = num / norm * focal_j  # distance in j's image of j's joint k to i's epipolar line
            # ... and in i's image: E[cam_i, cam_j] applied to j's joint, against i's joint.
            lines_i = np.einsum("jiab,jkb->ijka", e_pair, xh_j)  # e_pair[j, i] = E[cam_i, cam_j]
            num_i = np.abs(np.einsum("ijka,ika->ijk", lines_i, xh))
            d_in_i = num_i / np.sqrt(lines_i[..., 0] ** 2 + lines_i[..., 1] ** 2) \
                * rig.focal_px[camera_index][:, None, None]
        d = 0.5 * (d_in_j + d_in_i)
        both = (weights[:, None, :] > 0) & (w_j[None, :, :] > 0) & np.isfinite(d)
        count = both.sum(axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(both, d, 0.0).sum(axis=2) / count
        out = np.minimum(out, np.where(count >= min_common_joints, mean, np.inf))
    out[camera_index[:, None] == camera_index[None, :]] = np.inf
    return out


def apply_memory(distances: F64, prior_user: I64, factor: float) -> F64:
    """Scale distances by ``factor`` between people that were the same user, by 1/factor between
    people that were different users (prior_user: (M,) user id or -1 when unknown)."""
    known = prior_user >= 0
    both = known[:, None] & known[None, :]
    same = both & (prior_user[:, None] == prior_user[None, :])
    out = np.where(same, distances * factor, distances)
    out = np.where(both & ~same, out / factor, out)
    return out


def cluster_people(distances: F64, camera_index: I64, max_distance: float) -> list[list[int]]:
    """Greedy average-linkage clustering with at most one person per camera per cluster.

    Repeatedly merges the two clusters with the smallest mean finite distance between their
    members, as long as it is below ``max_distance`` and they share no camera. Returns every
    person in exactly one cluster (singletons included), clusters sorted by their first member.
    """
    m = distances.shape[0]
    if distances.shape != (m, m) or camera_index.shape != (m,):
        raise InputError(f"distances must be (M, M) with M = {camera_index.shape[0]}, got {distances.shape}")
    clusters: list[list[int]] = [[i] for i in range(m)]
    cams: list[set[int]] = [{int(camera_index[i])} for i in range(m)]
    finite = np.isfinite(distances)
    dist0 = np.where(finite, distances, 0.0)
    # Sums and counts of finite pairwise distances between clusters, merged incrementally.
    link_sum = dist0.copy()
    link_cnt = finite.astype(np.float64)
    alive = np.ones(m, dtype=bool)
    while True:
        with np.errstate(invalid="ignore", divide="ignore"):
            link = np.where(link_cnt > 0, link_sum / link_cnt, np.inf)
        link[~alive, :] = np.inf
        link[:, ~alive] = np.inf
        np.fill_diagonal(link, np.inf)
        order = np.argsort(link, axis=None)
        merged = False
        for flat in order:
            a, b = divmod(int(flat), m)
            if not link[a, b] < max_distance:
                break
            if a > b or cams[a] & cams[b]:
                continue
            clusters[a].extend(clusters[b])
            cams[a] |= cams[b]
            alive[b] = False
            link_sum[a, :] += link_sum[b, :]
            link_sum[:, a] += link_sum[:, b]
            link_cnt[a, :] += link_cnt[b, :]
            link_cnt[:, a] += link_cnt[:, b]
            merged = True
            break
        if not merged:
            break
    out = [sorted(clusters[i]) for i in range(m) if alive[i]]
    out.sort(key=lambda c: c[0])
    return out


def associate(
    rig: CameraRig,
    camera_index: I64,
    xy: F64,
    weights: F64,
    prior_user: I64,
    params: AssociationParams,
) -> list[list[int]]:
    """Group M people of C views into physical people (lists of row indices, one camera each)."""
    d = epipolar_distances(rig, camera_index, xy, weights, params.min_common_joints)
    d = apply_memory(d, prior_user, params.memory_factor)
    return cluster_people(d, camera_index, params.max_epipolar_px)
