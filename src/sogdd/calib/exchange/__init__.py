"""A calibration in the files other tools read and write: ROS, Kalibr, mrcal, COLMAP, and sogdd's own.

Every format reads into and writes from one plain description of the cameras
(:class:`StoredRig`, :class:`StoredCamera`); a model or a rig a format cannot hold is refused
with the reason (``ValueError``), never approximated, and a round trip gives the numbers back to
float precision. ``sogdd convert IN OUT --to FORMAT`` is :func:`convert`.

:mod:`.stored`: :class:`StoredCamera` and :class:`StoredRig`, what the formats hold (:func:`stored_rig`), with
the optional uncertainties sogdd's own files hold (the drift check's, :mod:`sogdd.calib.drift`).
:mod:`.format`: :class:`~.format.ExchangeFormat`, what a format's record holds, and what the formats share.
:mod:`.registry`: the formats, one row per format: a new format is one module and one row.
:mod:`.native`: sogdd's own camera.yaml / rig.yaml (OpenCV FileStorage), camera.json / rig.json, folders,
read with their standard deviations (the one reader of sogdd's stored files).
:mod:`.ros`: ROS ``camera_info`` YAML (plumb_bob, rational_polynomial, equidistant; a stereo pair).
:mod:`.kalibr`: Kalibr's camchain YAML (pinhole and omni; radtan and equidistant; ``T_cn_cnm1``).
:mod:`.mrcal`: mrcal's ``.cameramodel`` (LENSMODEL_OPENCV4, 5, 8; ``extrinsics``).
:mod:`.colmap`: COLMAP cameras and rigs through pycolmap (OPENCV, FULL_OPENCV, OPENCV_FISHEYE).
:mod:`.mrgingham`: a calibration's corners as mrgingham's ``corners.vnl`` (``mrcal-calibrate-cameras``).
:mod:`.kalibr_corners`: a calibration's corners as Kalibr's target observations (its ids and target points).
:mod:`.conversion`: :func:`read_calibration`, :func:`write_calibration_as` and :func:`convert` in any format.
"""

from .conversion import convert, read_calibration, write_calibration_as
from .format import ExchangeFormat
from .kalibr_corners import read_kalibr_corners, write_kalibr_corners
from .mrgingham import write_corners_vnl
from .registry import FORMATS, detect, exchange_format
from .stored import StoredCamera, StoredRig, stored_rig

__all__ = ["FORMATS", "ExchangeFormat", "StoredCamera", "StoredRig", "convert", "detect", "exchange_format",
           "read_calibration", "read_kalibr_corners", "stored_rig", "write_calibration_as", "write_corners_vnl",
           "write_kalibr_corners"]
