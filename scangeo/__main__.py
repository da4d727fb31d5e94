import sys

from scangeo.cli import main

sys.exit(main())
