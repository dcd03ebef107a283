"""shockdyno: shock-absorber dyno controller, MCAP logger and damper model."""

__version__ = "0.1.0"

import os as _os

# The fits factor matrices of tens of columns, where BLAS threads cost far more in
# start-up and spinning than they save (0.5 s against 13 ms for one SVD on a busy
# 2-core machine). One thread unless the user asks for more; set before numpy loads.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")
