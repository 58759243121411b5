"""``python -m cam_metrology``: the same as the ``cam-bench`` command."""
import sys

from cam_metrology.cli import main

sys.exit(main())
