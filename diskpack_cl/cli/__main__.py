"""``python -m diskpack_cl.cli``: the ``diskpack`` command."""

import sys

from diskpack_cl.cli import main

sys.exit(main())
