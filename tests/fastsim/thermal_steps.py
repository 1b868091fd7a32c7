#!/usr/bin/env python3
"""FASTSim 3.1's engine thermal model (`FuelConverterThermal`) reconstructed step by step from its equations and
checked against FASTSim's own histories: the 2026 Chrysler Pacifica `_thrml` on UDDS at 22 °C, with FASTSim's
fuel, propulsion and auxiliary powers and speeds of the previous step as inputs (FASTSim heats the engine with
the previous step's values). The equations, per 1 s step, T in K:

  Q   = min(G (T_ad(T) − T), f_max (P_fuel − P_prop − P_aux))       heat into the engine
  s   = clamp((T − T_sto)/ΔT, 0, 1)                                  thermostat opening
  h   = (1 + s ε) h_stop                  if v < 1 m/s               standing: passive + radiator
      = s κ(T_film) L^(−0.195) v^0.805    otherwise                  a sphere's forced convection (Re ≥ 4e4)
  T  += (Q − h π L²/4 (T − T_amb)) dt / C
  c   = max(1 − exp(−(T − T_off)/λ), c_min)                          efficiency factor while cold

with T_ad and κ the fits invsim's importer uses (crates/import/src/thermal.rs). Prints the largest differences
of temperature and efficiency factor; exit status 1 if the temperature differs by more than 0.01 K.

Usage: python tests/fastsim/thermal_steps.py   (with the fastsim package installed)
"""
import math
import sys

import fastsim

T_AD = (2898.89026, 0.86256715)
KAPPA_R = 0.9328119859207017 * (7.44483605 - 0.00848548 * 330.0)
GAMMA = 0.00848548 / (7.44483605 - 0.00848548 * 330.0)


def main():
    veh = fastsim.Vehicle.from_resource("2026_Chrysler_Pacifica_Select_thrml.yaml")
    th = veh.to_dict()["pt_type"]["Conv"]["fc"]["thrml"]["FuelConverterThermal"]
    cyc = fastsim.Cycle.from_resource("udds.csv")
    params = fastsim.SimParams.default().to_dict()
    params["trace_miss_opts"] = "Allow"
    sd = fastsim.SimDrive(veh, cyc, fastsim.SimParams.from_dict(params))
    sd.walk()
    r = sd.to_dict(flatten=True)
    hist = "veh.pt_type.Conv.fc.thrml.FuelConverterThermal.history."
    fc = "veh.pt_type.Conv.fc.history."
    temp, coeff = r[hist + "temperature_kelvin"], r[hist + "eff_coeff"]
    v = r["veh.history.speed_ach_meters_per_second"]
    fuel, prop, aux = r[fc + "pwr_fuel_watts"], r[fc + "pwr_prop_watts"], r[fc + "pwr_aux_watts"]
    t_amb = r["cyc.temp_amb_air_kelvin"][0]
    c, length = th["heat_capacitance_joules_per_kelvin"], th["length_for_convection_meters"]
    h_stop, g = th["htc_to_amb_stop_watts_per_square_meter_kelvin"], th["conductance_from_comb_watts_per_kelvin"]
    f_max, eps = th["max_frac_from_comb"], th["radiator_effectiveness"]
    sto, delta = th["tstat_te_sto_kelvin"], th["tstat_te_delta_kelvin"]
    model = th["fc_eff_model"]["Exponential"]
    area = math.pi * length ** 2 / 4
    t_run, dt_max, dc_max = temp[0], 0.0, 0.0
    for i in range(1, len(temp)):
        s = min(max((t_run - sto) / delta, 0.0), 1.0)
        if v[i - 1] < 1.0:
            h = (1 + s * eps) * h_stop
        else:
            kappa = KAPPA_R / (1 + GAMMA * ((t_run + t_amb) / 2 - 330.0))
            h = s * kappa * length ** -0.195 * v[i - 1] ** 0.805
        q = min(g * (T_AD[0] + T_AD[1] * t_run - t_run), f_max * (fuel[i - 1] - prop[i - 1] - aux[i - 1]))
        t_run += (q - h * area * (t_run - t_amb)) / c
        eff = max(1 - math.exp(-(t_run - model["offset"]) / model["lag"]), model["minimum"])
        dt_max = max(dt_max, abs(t_run - temp[i]))
        dc_max = max(dc_max, abs(eff / coeff[i] - 1))
    print(f"UDDS, {len(temp)} steps: largest temperature difference {dt_max:.2e} K, "
          f"largest relative difference of the efficiency factor {dc_max:.2e}")
    return 0 if dt_max <= 0.01 else 1


if __name__ == "__main__":
    sys.exit(main())
