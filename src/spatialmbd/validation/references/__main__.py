"""``python -m spatialmbd.validation.references [--write]``."""
from . import main

raise SystemExit(main())
