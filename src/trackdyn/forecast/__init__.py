"""Ensemble forecasts of track deterioration: what varies between members
(`trackdyn.forecast.spread`) and the members' results summed up per segment as quantiles and
probabilities (`trackdyn.forecast.summary`)."""
