"""inkarm: a testbed for drawing robots.

Movement models (``inkarm.models``) turn sparse motor plans into human-like pen trajectories;
controllers (``inkarm.control``) make a plant track them: a MuJoCo arm (``inkarm.sim``) or real
devices (``inkarm.hardware``). Millimetres and seconds at every public surface.
"""

from inkarm.errors import InkarmError

__all__ = ["InkarmError", "__version__"]
__version__ = "0.1.0"
