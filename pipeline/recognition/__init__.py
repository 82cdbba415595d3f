"""Action recognition: the navigator's 3D skeleton -> still / forward / left / right, yaw and speed.

- ``features``: translation, rotation and scale normalisation, unknown joints, velocities.
- ``orientation``: facing yaw from hips, shoulders and head; its smoother.
- ``speed``: walking speed from the step cadence.
- ``recognizer``: the streaming :class:`~pipeline.recognition.recognizer.ActionRecognizer`
  (committed ``action.onnx`` via onnxruntime, EMA + hysteresis).
- ``metrics``: evaluation measures. ``model`` / ``train``: the SlowFast network and its
  training (torch, the ``train`` extra; never imported at run time).

See ``MODEL_CARD.md`` for the data, settings and measured figures.
"""
