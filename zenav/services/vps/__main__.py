from zenav.common.app import main

from .service import Vps

raise SystemExit(main(Vps))
