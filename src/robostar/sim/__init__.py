"""The virtual N1 controller: a model of the robot and controller, speaking the controller side
of the host protocol through the same command codecs the client uses.

``VirtualController`` is the byte peer a transport (``sim://``) or a server drives; ``SimConfig``
and ``ChannelConfig`` describe the controller; ``Model`` is its state, open to tests.
"""

from robostar.sim.config import ChannelConfig, SimConfig
from robostar.sim.controller import VirtualController
from robostar.sim.model import Model

__all__ = ["ChannelConfig", "Model", "SimConfig", "VirtualController"]
