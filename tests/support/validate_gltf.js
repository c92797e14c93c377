// Validates a .glb with the Khronos glTF validator: node validate_gltf.js VALIDATOR_DIR FILE.glb
// Prints the error/warning counts and each message; exits 1 on any error.
const validator = require(process.argv[2]);
const fs = require('fs');
validator.validateBytes(new Uint8Array(fs.readFileSync(process.argv[3])))
    .then((r) => {
        const i = r.issues;
        console.log(`gltf-validator: ${i.numErrors} errors, ${i.numWarnings} warnings, ` +
                    `${i.numInfos} infos`);
        for (const m of i.messages) console.log(`  ${m.severity} ${m.code} ${m.pointer || ''}: ${m.message}`);
        process.exit(i.numErrors > 0 ? 1 : 0);
    })
    .catch((e) => { console.log(`gltf-validator failed: ${e}`); process.exit(1); });
