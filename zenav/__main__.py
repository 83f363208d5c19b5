"""`python -m zenav`: the zenav command."""

import sys

from zenav.cli.main import main

sys.exit(main())
