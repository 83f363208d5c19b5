from zenav.common.app import main

from .service import Motor

raise SystemExit(main(Motor))
