# Run from a scratch directory: python3 scripts/motor_speed_scatter.py PATH/TO/truss-deploy
# Seeded scatter of speed-driven masts: start 25-40 deg, damping 0.3-1.0, mu 0-0.1,
# joint mass 0.1-0.2 kg, speed 0.005-0.02 m/s, 2-6 units. Oracle: deploy time =
# (L(start) - L(60 deg)) / s whenever the motor tracked to the latch.
import json, math, random, subprocess, sys
B = sys.argv[1] if len(sys.argv) > 1 else "target/release/truss-deploy"
rng = random.Random(20261126)
rows = []
for i in range(30):
    p = dict(units=rng.randint(2, 6), start=rng.uniform(25, 40), damp=rng.uniform(0.3, 1.0),
             mu=rng.uniform(0, 0.1), mass=rng.uniform(0.1, 0.2), speed=rng.uniform(0.005, 0.02))
    subprocess.run([B, "generate", "mast", "--units", str(p["units"]), "--start-deg", str(p["start"]),
                    "--damping", str(p["damp"]), "--mu", str(p["mu"]), "--joint-mass-kg", str(p["mass"]),
                    "-o", f"m{i}.toml"], check=True, capture_output=True)
    r = subprocess.run([B, "simulate", f"m{i}.toml", "--motor-speed", f"drive={p['speed']}",
                        "--json", f"s{i}.json"], capture_output=True, text=True)
    s = json.load(open(f"s{i}.json"))
    n, l = p["units"], 0.5
    reel = (n + 1) * l * (math.cos(math.radians(p["start"])) - math.cos(math.radians(60)))
    t_exact = reel / p["speed"]
    st = s["solver_stats"]
    fb = {k: v for k, v in st["fallbacks"].items() if v}
    rows.append((i, r.returncode, s["deployed"], s["deploy_time_s"], abs(s["deploy_time_s"] - t_exact) if s["deploy_time_s"] else None,
                 s["energy_balance_rel_error"], st["motor_releases"], st["motor_engagements"], fb))
    print(*rows[-1], flush=True)
ok = [r for r in rows if r[1] == 0 and r[2]]
print("deployed", len(ok), "of", len(rows))
print("max |t - reel/s|", max(r[4] for r in ok), "max balance", max(r[5] for r in ok))
print("runs with any fallback", sum(1 for r in rows if r[8]))
