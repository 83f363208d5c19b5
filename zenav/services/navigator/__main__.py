from zenav.common.app import main

from .service import Navigator

raise SystemExit(main(Navigator))
