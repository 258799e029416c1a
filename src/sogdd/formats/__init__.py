"""Formats: what detection writes and what other tools read.

=======================  =============================================================
module                   what it does
=======================  =============================================================
:mod:`.features`         the feature-file schema (npz, CSV, JSON), atomic writes,
                         :func:`load_features` / :func:`read_features`
:mod:`.safe_write`       atomic writes with the user's permissions, never over an input
:mod:`.record`           one image's record: corners, parameters, the source file's stamp
:mod:`.feature_csv`      the CSV layout: plain rows, the provenance in a ``.json`` sidecar
:mod:`.colmap`           the COLMAP adapter: the +0.5 pixel shift, cameras, feature
                         export (``pip install 'sogdd[sfm]'``, imported lazily)
:mod:`.colmap_database`  a database file checked before it is touched, copied whole,
                         pycolmap's log lines captured, stale rows deleted
=======================  =============================================================
"""

from .features import FORMATS, FeatureRecord, load_features, read_features, write_features

__all__ = ["FORMATS", "FeatureRecord", "load_features", "read_features", "write_features"]
