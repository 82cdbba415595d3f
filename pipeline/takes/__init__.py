"""Takes: recordings of the running pipeline (SPEC.md "Takes") and the prompted protocols that label them.

- :mod:`pipeline.takes.protocol` — protocol TOML files (steps such as ``forward 8 s``) and the
  label spans they give, with a reaction margin around every change;
- :mod:`pipeline.takes.recorder` — a take written as it goes (a crash loses at most the last second);
- :mod:`pipeline.takes.files` — reading, checking, finishing, recovering and relabelling a take folder;
- :mod:`pipeline.takes.video` — the camera videos, written in the capture workers;
- :mod:`pipeline.takes.export` — a take for other tools: zip/folder, TRC, labels table.
"""
