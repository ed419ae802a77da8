"""Run the ``geoalpha`` command: ``python -m geoalpha``."""

from geoalpha._cli import main

if __name__ == "__main__":
    main(prog_name="geoalpha")
