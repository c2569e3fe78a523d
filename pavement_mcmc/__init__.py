"""pavement_mcmc: Bayesian estimation of ground thermal properties and the surface heat transfer
coefficient from buried temperature sensors, with model criticism.

Data flow (one way): data -> physics -> solver -> posterior -> samplers -> storage ->
diagnostics / sensitivity / criticism / plotting / report / cli.
"""

__version__ = "0.1.0"
