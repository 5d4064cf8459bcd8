"""pyplot with the file-only Agg backend, set here once: heft writes figures to files and
never opens a window (it runs headless in tests, sweeps and on the lab's controller)."""

import matplotlib

matplotlib.use("Agg")

from matplotlib import pyplot as plt  # noqa: E402  (the backend must be chosen first)

__all__ = ["plt"]
