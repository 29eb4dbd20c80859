"""Files: model TOML (structures and plain matrices), test data (JSON, universal files), results."""

from .model_file import load_matrix, load_model
from .results import atomic_write_text, to_jsonable, write_json
from .testdata_json import load_testdata, parse_testdata
from .uff import read_uff, write_uff_frf, write_uff_modes

__all__ = [
    "load_model", "load_matrix", "load_testdata", "parse_testdata",
    "read_uff", "write_uff_modes", "write_uff_frf",
    "write_json", "atomic_write_text", "to_jsonable",
]
