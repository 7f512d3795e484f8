"""Does one simulated drape describe a fabric better than its omega? (data only, no nets)

Usage: python3 benches/fabric_probe.py DATASET   (numpy only; book/src/experiments/one-drape.md)

For each held-out fabric F (the paper's four targets against every other fabric; and each
fabric left out in turn), at every frame f >= 1, the fitting labels L(F, f) = smoothed -
body (world frame) are predicted from the other fabrics' true labels at the same frame:
nearest fabric and inverse-distance blend of the 3 nearest by omega or by the reference
drape (L at frame 0), weights fitted so the others' frame-0 labels reproduce F's (ridge,
affine, non-negative) and reused at f, and two oracles that look at the answer (best single
fabric; best linear combination at f). Error: mean per-vertex Euclidean distance, mm;
"@f>=10" is the same over frames 10 and later only.
"""
import json, sys, os
import numpy as np

d = sys.argv[1]
m = json.load(open(os.path.join(d, "manifest.json")))
mats = m["materials"]
names = [x["name"] for x in mats]
omega = np.array([x["omega_normalized"] for x in mats])
P = len(m["poses"])
M = len(names)
# The manifest lists the finished samples; a fabric counts once all its poses are there.
stems = {(r["material"], r["pose"]): r["stem"] for r in m["samples"]}
complete = [mi for mi in range(M) if all((mi, p) in stems for p in range(P))]
print(f"{len(complete)} of {M} fabrics complete")
L = np.zeros((M, P, m["template"]["vertex_count"], 3), np.float32)
for mi in complete:
    for p in range(P):
        s = os.path.join(d, "samples", stems[(mi, p)])
        L[mi, p] = np.load(os.path.join(s, "smoothed.npy")) - np.load(os.path.join(s, "body.npy"))

def err(a, b):
    return 1000 * np.linalg.norm(a - b, axis=-1).mean()

def ridge_weights(A, y, lam, affine):
    # A: [k, D] training descriptors, y: [D]; min |A^T w - y|^2 + lam |w|^2 (+ sum w = 1)
    G = A @ A.T + lam * np.eye(len(A))
    b = A @ y
    if not affine:
        return np.linalg.solve(G, b)
    k = len(A)
    K = np.zeros((k + 1, k + 1)); K[:k, :k] = G; K[:k, k] = 1; K[k, :k] = 1
    r = np.concatenate([b, [1.0]])
    return np.linalg.solve(K, r)[:k]

def nnls(A, y, iters=2000):
    # projected gradient, w >= 0
    G = A @ A.T; b = A @ y
    w = np.full(len(A), 1.0 / len(A))
    step = 1.0 / np.linalg.eigvalsh(G).max()
    for _ in range(iters):
        w = np.maximum(0, w - step * (G @ w - b))
    return w

def evaluate(target, train, ref=0):
    frames = [p for p in range(P) if p != ref]
    desc = L[:, ref].reshape(M, -1)
    dw = np.linalg.norm(omega[train] - omega[target], axis=1)
    dd = np.array([err(L[t, ref], L[target, ref]) for t in train])
    res = {}
    def idw(dist, k=3):
        o = np.argsort(dist)[:k]; w = 1 / np.maximum(dist[o], 1e-9); return o, w / w.sum()
    A = desc[train]; y = desc[target]
    scale = np.abs(A).max()
    wr = {f"ridge{lam:g}": ridge_weights(A / scale, y / scale, lam, False) for lam in (1e-3, 1e-1, 1)}
    wr.update({f"affine{lam:g}": ridge_weights(A / scale, y / scale, lam, True) for lam in (1e-3, 1e-1, 1)})
    wr["nnls"] = nnls(A / scale, y / scale)
    for f in frames:
        truth = L[target, f]
        T = L[train, f]
        e = np.array([err(T[i], truth) for i in range(len(train))])
        res.setdefault("nearest_omega", []).append(e[np.argmin(dw)])
        res.setdefault("nearest_desc", []).append(e[np.argmin(dd)])
        res.setdefault("oracle_single", []).append(e.min())
        for nm, dist in (("idw3_omega", dw), ("idw3_desc", dd)):
            o, w = idw(dist)
            res.setdefault(nm, []).append(err(np.tensordot(w, T[o], 1), truth))
        for nm, w in wr.items():
            res.setdefault("w_" + nm, []).append(err(np.tensordot(w, T, 1), truth))
        # oracle linear at this frame
        wo = ridge_weights(T.reshape(len(train), -1) / scale, truth.reshape(-1) / scale, 1e-3, False)
        res.setdefault("oracle_linear", []).append(err(np.tensordot(wo, T, 1), truth))
    late = {k + "@f>=10": float(np.mean(v[9:])) for k, v in res.items() if k in ("nearest_omega", "idw3_omega", "nearest_desc", "w_ridge1", "oracle_single")}
    out = {k: float(np.mean(v)) for k, v in res.items()}
    out.update(late)
    return out, float(dw.min()), float(dd.min())

targets = ["Sherpa Fleece 160", "Silk Duchess Satin", "Trim Fusible Rigid", "Cashmere"]
presets_train = [i for i in complete if names[i] not in targets and not names[i].startswith(("random-", "mix-"))]
all_train = [i for i in complete if names[i] not in targets]
targets = [t for t in targets if names.index(t) in complete]
for label, train in (("the other presets", presets_train), ("all non-targets", all_train)):
    if label == "all non-targets" and len(all_train) == len(presets_train):
        continue
    print(f"== targets, trained on {label} ({len(train)})")
    rows = {}
    for t in targets:
        r, dwm, ddm = evaluate(names.index(t), train)
        rows[t] = r
        print(f"  {t:22s} omega-dist {dwm:.3f}  desc-dist {ddm:6.2f} mm  " + "  ".join(f"{k} {v:.2f}" for k, v in r.items()))
    keys = next(iter(rows.values())).keys()
    print("  MEAN " + "  ".join(f"{k} {np.mean([rows[t][k] for t in targets]):.2f}" for k in keys))
for label, pool in (("presets", presets_train), ("all non-targets", all_train)):
    print(f"== leave-one-out over {label} ({len(pool)}; train = the others, targets excluded)")
    rows = [evaluate(t, [i for i in pool if i != t])[0] for t in pool]
    keys = rows[0].keys()
    print("  MEAN " + "  ".join(f"{k} {np.mean([r[k] for r in rows]):.2f}" for k in keys))
    print("  MEDIAN " + "  ".join(f"{k} {np.median([r[k] for r in rows]):.2f}" for k in keys))
