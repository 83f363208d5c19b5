from zenav.common.app import main

from .service import Localizer

raise SystemExit(main(Localizer))
