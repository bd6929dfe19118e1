r"""Data sets: many simulated runs of one scenario with drawn parameters, generated on Dask.

::

    from sionnafmcw import dataset
    spec = dataset.load_spec("plates.yaml")        # or a dict; SpecError names the field and the fix
    index = dataset.generate(spec, "data/plates")  # LocalCluster by default; scheduler="tcp://..." for a cluster
    index = dataset.open_index("data/plates")      # xarray.Dataset: items, parameters, status, labels

Modules: :mod:`.spec` (the spec format and the reproducible draw of items), :mod:`.generate`
(items as Dask tasks, resume, failures), :mod:`.cluster` (the local cluster or a scheduler's, and a
local cluster's quiet close), :mod:`.index` (folder layout, labels, the index).
:mod:`sionnafmcw.tf` streams a generated data set into TensorFlow.
"""

from .generate import DatasetWarning, generate, run_item
from .index import DatasetError, item_dir, open_index, store_labels, store_state
from .spec import DatasetSpec, Item, SpecError, load_spec

__all__ = ["DatasetError", "DatasetSpec", "DatasetWarning", "Item", "SpecError", "generate", "item_dir", "load_spec",
           "open_index", "run_item", "store_labels", "store_state"]
