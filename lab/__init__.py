"""Whole-body control lab."""

import os

# Every matrix here is tens of rows: a multi-threaded BLAS only adds hand-over cost, its idle
# workers spin on the cores the 1 kHz loop needs, and joining them at exit took seconds.
# Set here so that it holds before numpy is first imported, in every entry point.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
