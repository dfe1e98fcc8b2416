"""atlas: datasets and the netCDF files they are stored in.

``dataset`` (the CF header every Dataset starts with, and what kind a Dataset is),
``write`` (CF-compliant netCDF writing: ``write_atlas``, encodings and chunks),
``atomic`` (files that appear whole or not at all, whatever signal arrives), ``read``
(``open_atlas`` and the summary ``describe_atlas``) and ``cfcheck`` (the CF checker,
run on written atlases).
"""

from phasemap.atlas.read import describe_atlas, open_atlas
from phasemap.atlas.write import write_atlas

__all__ = ["describe_atlas", "open_atlas", "write_atlas"]
