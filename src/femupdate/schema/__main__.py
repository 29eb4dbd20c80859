"""``python -m femupdate.schema FILE.md``: rewrite the schema's marked parts of FILE.md."""

import sys
from pathlib import Path

from . import rewrite

for name in sys.argv[1:]:
    path = Path(name)
    path.write_text(rewrite(path.read_text(encoding="utf-8")), encoding="utf-8")
