"""A control law: the built-in position goals with the torque feed-forward scaled."""

from inkarm.control.laws.position_goals import PositionGoals


class ScaledFeedForward(PositionGoals):
    """:class:`PositionGoals` with its torque feed-forward times ``scale``."""

    starts = 0  # runs that started this law (what the test checks)

    def __init__(self, scale: float = 1.0, friction_adaptation: float | None = None):
        if not 0.0 <= scale <= 2.0:
            raise ValueError(f"scale: expected a number in [0, 2], got {scale}")
        super().__init__(friction_adaptation)
        self.scale = scale

    def start(self, context):
        super().start(context)
        type(self).starts += 1

    def command(self, state, setpoint):
        command = super().command(state, setpoint)
        return command._replace(torque=self.scale * command.torque)
