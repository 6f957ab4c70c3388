"""Bringing the user's own files in: a robot's URDF as a robot folder (`urdf`)."""
