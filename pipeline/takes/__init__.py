"""Takes: recordings of the running pipeline (SPEC.md "Takes") and the prompted protocols that label them.

- :mod:`pipeline.takes.protocol` — protocol TOML files (steps such as ``forward 8 s``) and the
  label spans they give, with a reaction margin around every change;
- :mod:`pipeline.takes.writer` — a take written as it goes (a crash loses at most the last second);
- :mod:`pipeline.takes.reader` — reading, checking and recovering a take folder.
"""
