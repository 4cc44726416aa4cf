from .base import ManiLadderEnv, UnsupportedControlModeError, UnsupportedRobotError, resolve_render_backend
from .registration import register_task
