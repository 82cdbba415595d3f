"""Identity that survives the room (issue 20 item 2): re-identification of people who leave and
come back (or whose 3D track broke) from their body measurements.

- :mod:`pipeline.identity.config`: :class:`IdentityConfig`, the settings' ``[identity]`` section.
- :mod:`pipeline.identity.body`: the body measurements of a skeleton (bone lengths, stature) and
  the distance between two people's.
- :mod:`pipeline.identity.gallery`: :class:`Gallery`, the people recently lost, and the decision
  whether a new track is one of them.
"""

from pipeline.identity.body import MEASURES, body_measures, measure_distance
from pipeline.identity.config import IdentityConfig
from pipeline.identity.gallery import Gallery, LostUser

__all__ = ["MEASURES", "Gallery", "IdentityConfig", "LostUser", "body_measures", "measure_distance"]
