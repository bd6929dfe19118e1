"""TI's mmWave toolchain in one place (numpy only, no Sionna).

* :mod:`sionnafmcw.ti.cfg` -- mmWave SDK / demo ``.cfg`` files in and out (:func:`read_ti_cfg`,
  :func:`write_ti_cfg`) and the boards they name (:data:`BOARDS`).
* :mod:`sionnafmcw.ti.devices` -- the devices' receivers from their data sheets (IF chain, ADC,
  phase noise).
* :mod:`sionnafmcw.ti.dca1000` -- DCA1000EVM raw ADC captures in and out (:func:`write_dca1000`,
  :func:`read_dca1000`), TI-layout ``.npz`` frames and :func:`export_run` from a run store.
* :mod:`sionnafmcw.ti.points` -- one frame of the out-of-box demo's output
  (:class:`~sionnafmcw.ti.points.DetectedPoints`).
"""

from .cfg import BOARDS, TiCfgError, parse_ti_cfg, read_ti_cfg, write_ti_cfg
from .dca1000 import CaptureError, export_run, read_dca1000, write_dca1000
from .points import DetectedPoints, GuiMonitor

__all__ = ["BOARDS", "CaptureError", "DetectedPoints", "GuiMonitor", "TiCfgError", "export_run", "parse_ti_cfg",
           "read_dca1000", "read_ti_cfg", "write_dca1000", "write_ti_cfg"]
