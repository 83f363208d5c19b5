from zenav.common.app import main

from .service import Driver

raise SystemExit(main(Driver))
