"""Motor primitives of handwriting: the factorial HMM of seed 004 (Williams, Toussaint, Storkey).

* :mod:`.model`: parameters (eq. 2-4 with the constraints of sec. 2.3 / Fig. 3), config, files.
* :mod:`.inference`: the structured variational E-step (eq. 7-9), a scaled forward-backward
  per chain, vectorised over sequences; the lower bound.
* :mod:`.learning`: the M-step (eq. 10-12) and the EM driver with the paper's initialisation
  and stopping rules.
* :mod:`.exact`: exact inference over the cross-product HMM (the test oracle).
* :mod:`.generate`: running the model generatively; scribbles (Fig. 8).
* :mod:`.features`: pen paths <-> normalised first differences at 200 Hz (sec. 3).
* :mod:`.reference`: one EM iteration as plain loops (log domain; the tests' reference) and the
  textbook scaled forward-backward (the benchmark's floor).
"""

from inkarm.models.primitives.inference import Batch, Posterior, e_step, lower_bound
from inkarm.models.primitives.learning import FitResult, Iteration, fit, initial_model, m_step
from inkarm.models.primitives.model import FORMAT_VERSION, PrimitiveModel, PrimitivesConfig

__all__ = [
    "FORMAT_VERSION",
    "Batch",
    "FitResult",
    "Iteration",
    "Posterior",
    "PrimitiveModel",
    "PrimitivesConfig",
    "e_step",
    "fit",
    "initial_model",
    "lower_bound",
    "m_step",
]
