"""cavewalk's recognition library: the stages of the method, importable without the web app.

Stages (one module or small package each, named as in the paper):
``sources`` (cameras, videos, simulator frames), ``calibration`` (ArUco/PnP),
``pose`` (YOLO-pose on ONNX Runtime), ``tracking`` (OC-SORT), ``triangulation``
(cross-view association, DLT, 3D tracks, navigator), ``recognition`` (skeleton
SlowFast, EMA, yaw, speed), ``emitter`` (UDP/OSC), ``sim`` (the CAVE simulator)
and ``runtime`` (worker processes and shared memory).
"""

__all__ = ["__version__"]
__version__ = "0.1.0"
