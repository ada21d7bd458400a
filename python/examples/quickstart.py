import pandas as pd
import stiction

loop = stiction.simulate(valve={"kind": "kano", "S": 4.0, "J": 1.0}, samples=1500, seed=2)
loop[["t", "SP", "PV", "OP"]].to_csv("loop.csv", index=False)

r = stiction.quantify(pd.read_csv("loop.csv"))
print(r["S"], r["J"], r["interval"]["S"], round(r["fit_pv_val"], 2))
print(r["warnings"])
c = stiction.compare("loop.csv", stiction=["kano", "he"], linear=["arx", "armax"])
for x in c["results"]:
    print(x["stiction_model"], x["linear_model"], x["S"], x["J"])
