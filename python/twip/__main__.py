import sys

from twip.cli import main

sys.exit(main())
