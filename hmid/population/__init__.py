"""A generic Hydro Muscle model: a population of muscles and the law from build to parameters.

The thesis's model is specific to one muscle (§8.1). A population study identifies several
muscles of different builds with the standard pipeline (:func:`identify_muscles`, a sweep), then
fits a hierarchical model of how each SLS parameter follows the specifications
(:func:`fit_population`: power laws with physically expected exponents as the prior's centre,
muscle-level scatter, each muscle's own posterior carried in), predicts a new muscle's force
model from its build (:func:`predict_muscle`, :func:`predicted_document`: an ``hmid-model/1``
file) and checks itself by leaving one muscle out (:func:`leave_one_out`).
"""

from hmid.population._config import Muscle, PopulationConfig, load_population
from hmid.population._data import muscle_dataset, retarget
from hmid.population._identify import Identified, identify_muscles
from hmid.population._law import EXPECTED, FEATURES, PARAMETERS
from hmid.population._model import Engine, PopulationFit, Priors, Sampler, fit_population
from hmid.population._predict import predict_muscle, predicted_document
from hmid.population._store import load_fit, save_fit
from hmid.population._summary import MuscleFit, from_run, summarise
from hmid.population._validate import leave_one_out

__all__ = [
    "EXPECTED",
    "FEATURES",
    "PARAMETERS",
    "Engine",
    "Identified",
    "Muscle",
    "MuscleFit",
    "PopulationConfig",
    "PopulationFit",
    "Priors",
    "Sampler",
    "fit_population",
    "from_run",
    "identify_muscles",
    "leave_one_out",
    "load_fit",
    "load_population",
    "muscle_dataset",
    "predict_muscle",
    "predicted_document",
    "retarget",
    "save_fit",
    "summarise",
]
