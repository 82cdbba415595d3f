"""The simulator as the pipeline's source (``cavewalk demo``): a picklable factory of ``SimWorld``.

The runtime builds the world inside its simulator worker process (``SimFactory`` of
``pipeline.runtime``); this module imports only ``pipeline`` so the worker stays light.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pipeline.camera import Camera
from pipeline.cave import CaveGeometry


@dataclass(frozen=True, slots=True)
class SimWorldFactory:
    """Builds ``SimWorld(cave, cameras, config)``; tells the main process the virtual cameras and rate."""

    cave: CaveGeometry
    cameras: tuple[Camera, ...]
    config: Any  # pipeline.sim.world.SimConfig
    fps: float

    def __post_init__(self) -> None:
        if not self.cameras:
            raise ValueError("the simulator needs at least one camera, got none")
        if self.fps <= 0:
            raise ValueError(f"fps must be > 0, got {self.fps}")

    def __call__(self) -> Any:
        from pipeline.sim.world import SimWorld

        return SimWorld(self.cave, list(self.cameras), self.config)

    @classmethod
    def from_parts(
        cls,
        cave: CaveGeometry,
        camera_preset: str,
        fps: float,
        bystanders: int,
        seed: int,
        camera_count: int = 4,
    ) -> SimWorldFactory:
        from pipeline.sim.scene import default_cameras
        from pipeline.sim.world import SimConfig

        config = SimConfig(
            fps=fps, bystanders=bystanders, seed=seed, camera_preset=camera_preset, camera_count=camera_count
        )
        cameras = tuple(default_cameras(cave, camera_preset, camera_count))
        return cls(cave, cameras, config, fps)
