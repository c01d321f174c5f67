"""A backend: the simulated arm, its runs noting that the demo plug-in drew them."""

from inkarm.jobs.backends.sim import SimBackend, SimSession


class DemoSession(SimSession):
    notes = ("drawn by the demo plug-in's backend",)


class DemoBackend(SimBackend):
    name = "demo"
    help = "the simulated arm, through the demo plug-in"

    def open(self, scenario, options):
        return DemoSession(scenario)


BACKEND = DemoBackend()  # a backend plug-in: the object itself
