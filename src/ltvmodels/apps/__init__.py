"""Applications built on the library: the paper's experiments and the demos.

* :mod:`.robot` — a two-link arm with friction and contact (paper Figs. 2–3);
* :mod:`.rl` — model-based reinforcement learning on a cart-pole (Section VIII,
  Fig. 4); :mod:`.gym_rl` — the same loop on gymnasium's Pendulum-v1;
  :mod:`.learning` — what the two loops share;
* :mod:`.demos` — the runners of ``ltvmodels demo`` (also used by ``examples/``).

Nothing here is imported by ``import ltvmodels``; the library never imports
from here.
"""

__all__: list[str] = []
