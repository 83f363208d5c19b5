from zenav.common.app import main

from .service import Sim

raise SystemExit(main(Sim))
