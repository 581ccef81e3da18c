from .run import *  # noqa: F401,F403
from .run import main  # noqa: F401
