import { html, render } from "/assets/vendor/htm-preact-standalone.module.js";
