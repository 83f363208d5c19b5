from zenav.common.app import main

from .service import Odometry

raise SystemExit(main(Odometry))
