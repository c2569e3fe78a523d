"""``python -m pavement_mcmc.cli`` runs the command line."""

import sys

from . import main

sys.exit(main())
