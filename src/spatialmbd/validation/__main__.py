"""python -m spatialmbd.validation [--full] [--out DIR] [case ...]"""
from . import main

raise SystemExit(main())
