"""Navigation modes (issue 20 item 1): who drives the locomotion, and how many streams go out.

- ``single``: one navigator (chosen or automatic, :mod:`pipeline.triangulation.navigator`), one
  stream: the paper's behaviour.
- ``each``: every tracked person (or a chosen set) has their own recogniser state and their own
  ``locomotion`` stream (``user_id`` = theirs; OSC ``/cave/locomotion/{user_id}``).
- ``group``: one shared command for the room (``user_id`` null), by the rule of
  :func:`pipeline.navigation.group.group_command`.
"""
