"""TI's mmWave toolchain in one place (numpy only, no Sionna).

* :mod:`sionnafmcw.ti.cfg` -- mmWave SDK / demo ``.cfg`` files in and out (:func:`read_ti_cfg`,
  :func:`write_ti_cfg`) and the boards they name (:data:`BOARDS`).
* :mod:`sionnafmcw.ti.devices` -- the devices' receivers from their data sheets (IF chain, ADC,
  phase noise).
* :mod:`sionnafmcw.ti.dca1000` -- DCA1000EVM raw ADC captures in and out (:func:`write_dca1000`,
  :func:`read_dca1000`), TI-layout ``.npz`` frames and :func:`export_run` from a run store.
* :mod:`sionnafmcw.ti.processing` -- the ``.cfg``'s processing lines of both SDK generations as a
  typed configuration (:class:`~sionnafmcw.ti.processing.TiProcessing`, :func:`processing_from_cfg`).
* :mod:`sionnafmcw.ti.oob` -- the out-of-box demo's on-chip chain, cube to points
  (:func:`~sionnafmcw.ti.oob.detect`, :func:`~sionnafmcw.ti.oob.run_point_clouds`).
* :mod:`sionnafmcw.ti.points` -- one frame of the out-of-box demo's output
  (:class:`~sionnafmcw.ti.points.DetectedPoints`).
* :mod:`sionnafmcw.ti.formats` -- the formats real pipelines read, written frame by frame: the
  demo's UART TLV stream, ROS 2 bags as TI's ROS 2 driver records them, RadHAR's text dumps and
  ``.npz`` (and one reader of RadHAR recordings, real or simulated).
* :mod:`sionnafmcw.ti.cfg_text` -- a ``.cfg``'s text as numbered commands, and :class:`TiCfgError`.
"""

from .cfg import BOARDS, TiCfgError, parse_ti_cfg, read_ti_cfg, write_ti_cfg
from .dca1000 import CaptureError, export_run, read_dca1000, write_dca1000
from .oob import detect, run_point_clouds
from .points import DetectedPoints, GuiMonitor
from .processing import TiProcessing, processing_from_cfg

__all__ = ["BOARDS", "CaptureError", "DetectedPoints", "GuiMonitor", "TiCfgError", "TiProcessing", "detect",
           "export_run", "parse_ti_cfg", "processing_from_cfg", "read_dca1000", "read_ti_cfg", "run_point_clouds",
           "write_dca1000", "write_ti_cfg"]
