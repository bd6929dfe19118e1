"""Interchange with TI's mmWave toolchain (numpy only, no Sionna).

* :mod:`sionnafmcw.io.ti_cfg` -- mmWave SDK / demo ``.cfg`` files in and out
  (:func:`read_ti_cfg`, :func:`write_ti_cfg`).
* :mod:`sionnafmcw.io.dca1000` -- DCA1000EVM raw ADC captures in and out
  (:func:`write_dca1000`, :func:`read_dca1000`), TI-layout ``.npz`` frames and
  :func:`export_run` from a run store.
"""

from .ti_cfg import BOARDS, TiCfgError, parse_ti_cfg, read_ti_cfg, write_ti_cfg
from .dca1000 import CaptureError, export_run, read_dca1000, write_dca1000

__all__ = ["BOARDS", "CaptureError", "TiCfgError", "export_run", "parse_ti_cfg", "read_dca1000", "read_ti_cfg",
           "write_dca1000", "write_ti_cfg"]
