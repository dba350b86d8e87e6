import sys

from sspinn.cli import main

sys.exit(main())
