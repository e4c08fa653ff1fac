"""python -m flexgen"""

from flexgen.cli import entry

entry()
