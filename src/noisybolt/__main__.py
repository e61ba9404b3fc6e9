"""``python -m noisybolt`` runs the command line."""

import sys

from noisybolt.cli import main

sys.exit(main())
