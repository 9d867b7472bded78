"""The optimizer's commands (``python -m optimizer.gala``, ``.ga``, ``.episode``, ``.transfer``) and
what they share (``common``)."""
