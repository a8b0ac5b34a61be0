"""actuator-design: equilibria, stability and design of magneto-elastic soft actuators."""
__version__ = "0.1.0"
