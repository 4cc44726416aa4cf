from .base import ManiLadderEnv, UnsupportedRobotError, resolve_render_backend
from .registration import register_task
