"""Runtime stage: the live, asynchronous multi-process pipeline (processes and shared memory).

The web app uses :class:`pipeline.runtime.pipeline.Pipeline` (start/stop, status, navigator,
workstations, events, snapshots); ``cavewalk bench`` and ``scripts/soak.py`` measure it.
Import from the modules themselves (``pipeline.runtime.pipeline``, ``.config``, ...): this
package imports nothing, so reading the settings does not start the whole runtime.
"""
