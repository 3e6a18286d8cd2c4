"""Shared pytest set-up."""

import os

# MuJoCo picks its OpenGL backend at import time: headless EGL unless the user chose one.
os.environ.setdefault("MUJOCO_GL", "egl")
